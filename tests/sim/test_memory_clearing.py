"""Remembered returns cleared once the sonar sees past them or the vehicle passes through them, and
the shield's ``remembered="cleared"`` reading only the rest: a fish school that fled from where the
sonar saw it stops blocking the way, also once it lies beside a forward-looking sonar, while the
policy's own observation keeps every remembered return (what it was trained on)."""
import math

import numpy as np
import pytest
from cage_sim.controller import ArcController
from cage_sim.driver import Driver
from cage_sim.memory import SWEEP_RADIUS, ReturnMemory
from cage_sim.mission import EnvConfig
from cage_sim.observation import ObservationBuilder
from cage_sim.shield import SafetyShield
from cage_sim.sonar import make_sonar

HALF = math.radians(1.0)


class Residual:
    """A learned policy that moves ``residual_base``'s action (the attribute ``policy.LoadedPolicy`` has)."""

    def __init__(self, base: ArcController):
        self.residual_base = base


def one_point(x: float, y: float) -> ReturnMemory:
    mem = ReturnMemory(bins=72, horizon=10.0)
    r, a = math.hypot(x, y), math.atan2(y, x)
    mem.add(np.array([r]), np.array([a]), np.array([[0.0, 0.0, 0.0]]), np.array([0.0]))
    return mem


@pytest.mark.parametrize("beam_range, bearing_deg, cleared", [
    (10.0, 0.0, True),          # the beam now reaches 10 m along the bearing of a return at 5 m
    (5.1, 0.0, False),          # it still ends there (within the margin): the same surface
    (np.inf, 0.0, True),        # no echo out to max range: nothing there
    (np.nan, 0.0, False),       # a bad range says nothing
    (10.0, 3.0, False),         # a beam 3 deg off, 1 deg wide, never looked there
])
def test_a_beam_clears_the_returns_it_sees_past_and_nothing_else(beam_range, bearing_deg, cleared):
    mem = one_point(5.0, 0.0)
    mem.clear_seen_past(np.array([beam_range]), np.array([math.radians(bearing_deg)]),
                        np.array([[0.0, 0.0, 0.0]]), HALF, max_range=20.0)
    assert bool(mem.cleared[0]) == cleared
    assert np.isfinite(mem.histogram(0.0, 0.0, 0.0)).sum() == 1             # the policy's view keeps it
    assert np.isfinite(mem.histogram(0.0, 0.0, 0.0, include_cleared=False)).sum() == (0 if cleared else 1)


def test_a_beam_fired_from_elsewhere_is_measured_from_where_it_fired():
    mem = one_point(5.0, 0.0)
    # from (5, -4) facing +y (yaw 90 deg), a beam straight ahead passes the return 4 m out and reaches 8 m
    mem.clear_seen_past(np.array([8.0]), np.array([0.0]), np.array([[5.0, -4.0, math.pi / 2]]), HALF, 20.0)
    assert mem.cleared[0]


def test_the_vehicle_clears_what_lies_on_its_track():
    near, far = one_point(3.0, SWEEP_RADIUS - 0.05), one_point(3.0, SWEEP_RADIUS + 0.05)
    for mem in (near, far):
        mem.clear_swept((0.0, 0.0), (6.0, 0.0))
    assert near.cleared[0] and not far.cleared[0]
    beyond = one_point(8.0, 0.0)
    beyond.clear_swept((0.0, 0.0), (6.0, 0.0))        # past the track's end
    assert not beyond.cleared[0]


def test_the_flags_follow_their_returns_through_pruning_and_the_cap():
    mem = ReturnMemory(bins=8, horizon=5.0, max_points=3)
    for k in range(4):                                 # returns at 1..4 m ahead, one a second
        mem.add(np.array([k + 1.0]), np.array([0.0]), np.array([[0.0, 0.0, 0.0]]), np.array([float(k)]))
        if k == 1:
            mem.cleared[-1] = True                     # the one at 2 m
    assert len(mem) == 3 and mem.cleared.tolist() == [True, False, False]
    mem.prune(6.5)                                     # forgets t < 1.5: the cleared one at t=1
    assert mem.cleared.tolist() == [False, False] and np.allclose(mem.points[:, 0], [3.0, 4.0])


def fls_scans(builder: ObservationBuilder, school: bool, t: float, pose=(0.0, 0.0, 0.0)) -> np.ndarray:
    """An fls scan with nothing in range but, when ``school``, an echo 3 m dead ahead."""
    lay = builder.layout
    ranges = np.full(lay.n_beams, np.inf)
    if school:
        ranges[np.argmin(np.abs(lay.angles))] = 3.0
    return builder.build(ranges, *pose, t, 15.0, 0.0, np.array([1.0, 0.0]))


def test_a_fled_school_is_cleared_for_the_shield_but_stays_in_the_policys_observation():
    layout = EnvConfig(sonar="fls", velocity=True, memory_bins=72).layout
    plain, clearing = ObservationBuilder(layout), ObservationBuilder(layout)
    clearing.clear_with(0.5 * make_sonar("fls").beam_width)
    for b in (plain, clearing):
        fls_scans(b, True, 0.0)                        # a school 3 m ahead...
    obs = [fls_scans(b, False, 1.0) for b in (plain, clearing)]   # ...gone a second later: the beam sees past
    assert np.array_equal(obs[0], obs[1])              # the policy reads the same either way
    assert np.isfinite(clearing.memory.histogram(0.0, 0.0, math.pi / 2, include_cleared=False)).sum() == 0 and (layout.memory_from(obs[1]) < 19.99).sum() == 1
    # The vehicle turns 90 deg left: the old place is now at -90 deg, outside the 130 deg sector,
    # where no beam can clear it again. The shield's "out_of_view" counts it there; "cleared" does not.
    turned = [fls_scans(b, False, 2.0, (0.0, 0.0, math.pi / 2)) for b in (plain, clearing)]
    assert np.array_equal(turned[0], turned[1])
    assert np.allclose(ArcController(layout, remembered="out_of_view").returns(turned[1]), [[0.0, -3.0]], atol=0.1)
    ctrl = ArcController(layout, remembered="cleared")
    assert len(ctrl.returns(turned[1])) == 1           # from the observation alone it cannot tell
    assert len(ctrl.returns(turned[1], memory=clearing.memory.histogram(0.0, 0.0, math.pi / 2, include_cleared=False))) == 0


def test_a_return_still_seen_is_never_cleared():
    layout = EnvConfig(sonar="fls", velocity=True, memory_bins=72).layout
    b = ObservationBuilder(layout)
    b.clear_with(0.5 * make_sonar("fls").beam_width)
    for t in range(5):
        fls_scans(b, True, float(t))                   # the same echo, 3 m ahead, every second
    assert not b.memory.cleared.any() and np.isclose(np.nanmin(b.memory.histogram(0.0, 0.0, 0.0, include_cleared=False)), 3.0)


def test_the_driver_clears_only_for_a_controller_that_reads_the_cleared_memory():
    config = EnvConfig(sonar="fls", velocity=True, memory_bins=72)
    lay, veh = config.layout, config.vehicle
    for remembered, cone in (("all", None), ("out_of_view", None), ("cleared", 0.5 * config.sonar.beam_width)):
        ctrl = ArcController(lay, veh, remembered=remembered)
        assert Driver(SafetyShield(ctrl, ctrl), lay, veh, sonar=config.sonar).builder.cone == cone
        assert Driver(ctrl, lay, veh, sonar=config.sonar).builder.cone == cone          # the baseline too
    ctrl = ArcController(lay, veh, remembered="cleared")
    assert Driver(ctrl, lay, veh, perception=False).builder.cone is None    # reads the observation alone
    # A raw residual policy: its base perceives (as in decide_batch), so a base reading the cleared
    # memory gets it cleared, not the observation's memory filtered by bins alone.
    assert Driver(Residual(ctrl), lay, veh, sonar=config.sonar).builder.cone == 0.5 * config.sonar.beam_width
    assert Driver(Residual(ArcController(lay, veh)), lay, veh, sonar=config.sonar).builder.cone is None
    wide = make_sonar("fls", beam_width_deg=4.0)
    assert math.isclose(Driver(ctrl, lay, veh, sonar=wide).builder.cone, math.radians(2.0))
    with pytest.raises(ValueError, match="half-width"):
        ObservationBuilder(lay).clear_with(-0.1)


def test_a_scanning_layout_reads_the_given_memory_as_its_scan():
    layout = EnvConfig(sonar="scanning", velocity=True, memory_bins=72, scan_in_obs=False).layout
    memory = np.full(72, np.inf)
    memory[18] = 4.0                                    # 4 m to the left
    obs = layout.build(None, 15.0, 0.0, np.array([1.0, 0.0]), np.full(72, np.inf))
    ctrl = ArcController(layout, remembered="cleared")
    assert len(ctrl.returns(obs)) == 0
    assert np.allclose(ctrl.returns(obs, memory=memory), [[0.0, 4.0]], atol=1e-9)


def test_the_cleared_memory_is_read_only_from_the_builder_that_built_the_observation():
    """A driver reading another builder's observation would read a memory that never saw those
    scans: refused, naming the fix, rather than flown on a stale memory."""
    from cage_sim.driver import Moment, decide_batch
    config = EnvConfig(sonar="fls", velocity=True, memory_bins=72)
    ctrl = ArcController(config.layout, config.vehicle, remembered="cleared")
    mine, other = Driver(ctrl, config.layout, config.vehicle), ObservationBuilder(config.layout)
    obs = fls_scans(other, True, 0.0)
    with pytest.raises(RuntimeError, match="use_builder"):
        decide_batch([mine], obs[None], [Moment((0.0, 0.0, 0.0), 0.0, (1.0, 0.0), False)])
    mine.use_builder(other)
    assert other.cone == 0.5 * config.sonar.beam_width
    act, _ = decide_batch([mine], obs[None], [Moment((0.0, 0.0, 0.0), 0.0, (1.0, 0.0), False)])
    assert np.isfinite(act).all()


def test_an_offline_episode_reads_the_memory_its_observations_are_built_with():
    from cage_sim.env import CageNavEnv
    from cage_sim.rollout import drive_episode
    config = EnvConfig(sonar="fls", velocity=True, memory_bins=72)
    env = CageNavEnv("cage?current=0.25&schools=2", config)
    ctrl = ArcController(config.layout, config.vehicle, remembered="cleared")
    driver = Driver(ctrl, config.layout, config.vehicle, sonar=config.sonar)
    ep = drive_episode(env, driver, seed=3)
    assert driver.builder is env.mission.builder and env.mission.builder.cone == 0.5 * config.sonar.beam_width
    assert ep.outcome in ("goal", "collision", "wander", "timeout") and ep.steps > 0


def test_the_one_origin_shortcut_clears_what_each_beam_measured_alone_does():
    """The shortcut for an electronic sonar's scan (every beam from one pose) against the rule
    written out beam by beam, point by point; and a head whose beams fire from different poses."""
    rng = np.random.default_rng(5)
    pts = rng.uniform(-12, 12, (400, 2))
    ranges = np.where(rng.random(64) < 0.2, np.inf, rng.uniform(0.5, 15, 64))
    angles, half = np.linspace(-1.1, 1.1, 64), math.radians(1.0)
    for origins in (np.tile([0.3, -0.2, 0.4], (64, 1)),                       # one pose: the shortcut
                    np.column_stack([np.linspace(0, 1, 64), np.zeros(64), np.linspace(0, 0.3, 64)])):
        mem = ReturnMemory(bins=72)
        mem.points, mem.stamps, mem.cleared = pts.copy(), np.zeros(len(pts)), np.zeros(len(pts), dtype=bool)
        mem.clear_seen_past(ranges, angles, origins, half, 20.0)
        expected = np.zeros(len(pts), dtype=bool)
        for (ox, oy, yaw), a, r in zip(origins, angles, ranges):
            reach = 20.0 if math.isinf(r) else r
            for m, (px, py) in enumerate(pts):
                off = abs((math.atan2(py - oy, px - ox) - (yaw + a) + math.pi) % (2 * math.pi) - math.pi)
                expected[m] |= off <= half and math.hypot(px - ox, py - oy) < reach - 0.3
        assert expected.sum() > 10 and np.array_equal(mem.cleared, expected)


def test_the_trainers_labeller_reads_each_missions_cleared_memory():
    """``FlownLabeller`` (the residual base's action in training) with a base reading the cleared
    memory: each env's driver reads the memory its mission's observations are built with, clearing
    on, and labels as the evaluator's driver of that mission decides, missions ending and starting."""
    from cage_sim.driver import FlownLabeller, decide_batch, mission_moment
    from cage_sim.vec_env import CageNavVecEnv
    config = EnvConfig(sonar="fls", velocity=True, memory_bins=72)
    ctrl = ArcController(config.layout, config.vehicle, remembered="cleared")
    envs = CageNavVecEnv(3, "cage?current=0.25&schools=3&obstacles=small", config, seed=6)
    labeller = FlownLabeller(ctrl, config.sonar)
    obs, _ = envs.reset()
    ref: dict[int, Driver] = {}
    missions = set()
    for _ in range(150):
        labels, _ = labeller(obs, envs.missions)
        for i, m in enumerate(envs.missions):
            if id(m) not in ref:   # as evaluate builds its drivers: one per mission, on its builder
                ref[id(m)] = Driver(ctrl, config.layout, config.vehicle, m.builder, sonar=config.sonar)
                missions.add(id(m))
            assert labeller.drivers[i].builder is m.builder and m.builder.cone == 0.5 * config.sonar.beam_width
        want, _ = decide_batch([ref[id(m)] for m in envs.missions], obs, [mission_moment(m) for m in envs.missions])
        assert np.allclose(labels[:, 0], want)
        obs, *_ = envs.step(labels)
    assert len(missions) > 3                                   # missions ended and new ones began
    assert any(m.builder.memory.cleared.any() for m in envs.missions)
