"""The known map as points for the shield: on the outlines, in the body frame, and what it changes."""
import math

import numpy as np
import pytest

from cage_sim.controller import ArcController
from cage_sim.driver import Driver, Moment, decide_batch, with_map
from cage_sim.map_points import MapPoints
from cage_sim.perception import Perception
from cage_sim.ros_convert import map_to_world, world_to_map
from cage_sim.shield import SafetyShield
from cage_sim.world import Obstacle, World

WORLD = World(30.0, (Obstacle("square", 5.0, -3.0, 2.0), Obstacle("circle", -6.0, 4.0, 1.5)),
              (Obstacle("circle", 0.0, 10.0, 0.3),), current=(0.3, 0.0), net_loss=None)


def test_segment_clearance_is_the_nearest_point_to_the_segment():
    known = MapPoints.from_world(WORLD)
    rng = np.random.default_rng(4)
    for _ in range(30):
        a, b = rng.uniform(-12, 12, 2), rng.uniform(-12, 12, 2)
        s = np.linspace(0.0, 1.0, 4001)[:, None]
        along = a + s * (b - a)                                  # the segment, every few mm
        brute = np.sqrt(((along[:, None, :] - known.points[None]) ** 2).sum(axis=-1)).min()
        assert known.segment_clearance(a, b) == pytest.approx(brute, abs=0.01)
    assert known.segment_clearance((5.0, -1.5), (5.0, -1.5)) == pytest.approx(0.5)   # a point: 0.5 m above the square
    assert MapPoints(np.zeros((0, 2))).segment_clearance((0, 0), (1, 1)) == math.inf


def test_points_lie_on_the_known_outlines_and_the_nominal_circle_every_half_metre():
    pts = MapPoints.from_world(WORLD).points
    on_net = np.isclose(np.hypot(pts[:, 0], pts[:, 1]), 30.0)
    on_known = np.array([min(abs(ob.distance(x, y)) for ob in WORLD.known) < 1e-9 for x, y in pts])
    assert np.all(on_net | on_known)
    unknown = WORLD.unknown[0]
    assert min(abs(unknown.distance(x, y)) for x, y in pts) > 0.1     # the sonar's to find, not the map's
    # the circle, not the wall the 0.3 m/s current pushes in (the map keeps the nominal net)
    assert WORLD.net.deformed and on_net.sum() >= 2 * math.pi * 30.0 / 0.5
    for ob in WORLD.known:   # every outline point within a quarter spacing of a map point
        th = np.linspace(0, 2 * math.pi, 400, endpoint=False)
        r = ob.size if ob.shape == "circle" else ob.size / 2 / np.maximum(np.abs(np.cos(th)), np.abs(np.sin(th)))
        outline = np.c_[ob.x + r * np.cos(th), ob.y + r * np.sin(th)]
        gap = np.min(np.hypot(*(outline[:, None, :] - pts[None, :, :]).transpose(2, 0, 1)), axis=1)
        assert gap.max() <= 0.25 + 1e-9


def test_near_gives_body_frame_points_within_the_radius():
    mp = MapPoints(np.array([[0.0, 5.0], [3.0, 0.0], [0.0, -30.0]]))
    body = mp.near((0.0, 0.0, math.pi / 2), 10.0)          # facing +y: (0, 5) is 5 m ahead, (3, 0) 3 m right
    assert np.allclose(body, [[5.0, 0.0], [0.0, -3.0]])
    assert mp.near((100.0, 0.0, 0.0), 10.0).shape == (0, 2)


def test_the_graph_gets_the_same_points_from_the_map_message():
    sent = map_to_world(world_to_map(WORLD, 0))
    assert np.array_equal(MapPoints.from_world(sent).points, MapPoints.from_world(WORLD).points)


@pytest.mark.parametrize("spacing", [0.0, -1.0, math.nan, math.inf])
def test_a_bad_spacing_is_refused(spacing):
    with pytest.raises(ValueError, match="spacing"):
        MapPoints.from_world(WORLD, spacing)


def test_a_map_too_large_for_the_shield_is_refused_before_it_is_built():
    with pytest.raises(ValueError, match="map too large.*net_radius 1e\\+06"):
        MapPoints.from_world(World(1e6))


class Constant:
    def __init__(self, a: float):
        self.a = a

    def act(self, obs):
        return np.full((len(obs), 1), self.a, dtype=np.float32)


def test_the_shield_keeps_off_a_known_face_the_sonar_has_not_seen():
    # A 2 m square ahead-left whose near corner is 0.5 m left of the track: the sonar has returned
    # only that corner (a scanning head has not yet swept the faces behind it). A hard left turn
    # keeps 1 m from the corner point, but not from the square; the map has its faces.
    square = Obstacle("square", 4.5, 1.5, 2.0)           # body frame = map frame here (pose at the origin)
    corner = np.array([[3.5, 0.5]])
    p = Perception(corner, drift=np.zeros(2))
    shield = SafetyShield(Constant(1.0), ArcController())
    assert shield.check(1.0, 20.0, 0.0, p) == 1.0         # the returns alone let it turn in
    outline = MapPoints.from_world(World(30.0, (square,)), spacing=0.05).near((0.0, 0.0, 0.0), 20.0)
    assert shield.margins(np.array([1.0]), outline)[0] < shield.min_clearance
    known = MapPoints.from_world(World(30.0, (square,)))
    p_map = with_map(p, known.near((0.0, 0.0, 0.0), 20.0))
    assert len(p_map.returns) > len(p.returns) and np.all(p_map.velocities[1:] == 0)
    a = shield.check(1.0, 20.0, 0.0, p_map)
    assert a < 1.0                                         # the map's faces make the turn unsafe
    assert shield.margins(np.array([a]), outline)[0] >= shield.min_clearance - 0.05   # and what flies is clear
    assert with_map(p, None) is p
    assert with_map(p, known.near((100.0, 0.0, 0.0), 20.0)) is p   # nothing of the map within reach


def test_only_the_shield_sees_the_map_the_raw_policy_and_the_baseline_do_not():
    from cage_sim.env import CageNavEnv
    env = CageNavEnv("cage")
    obs, _ = env.reset(seed=3)
    known = MapPoints.from_world(env.mission.world)
    mo = Moment(env.mission.pose, 0.0, env.mission.velocity_over_ground(), False, None)
    for make in (lambda: ArcController(env.config.layout), lambda: Constant(0.4)):
        plain = decide_batch([Driver(make(), env.config.layout, env.config.vehicle)], obs[None], [mo])[0]
        mapped = decide_batch([Driver(make(), env.config.layout, env.config.vehicle, known=known)], obs[None], [mo])[0]
        assert np.array_equal(plain, mapped)


def test_choose_twice_decides_as_two_choose_calls():
    """The base's choice (scan alone) and the shield's fallback choice (scan and map) from one
    clearance of the returns: the same answers as ``choose`` on each perception, in random scenes
    with moving returns, a drift and the goal near or far."""
    rng = np.random.default_rng(5)
    ctrl = ArcController()
    differ = 0
    for _ in range(60):
        returns = rng.uniform(-8, 12, size=(int(rng.integers(0, 40)), 2))
        vel = np.where(rng.random((len(returns), 1)) < 0.2, rng.normal(0, 0.4, (len(returns), 2)), 0.0)
        p = Perception(returns, vel, rng.normal(0, 0.25, 2), bool(rng.random() < 0.5))
        extra = rng.uniform(-10, 12, size=(int(rng.integers(1, 60)), 2))
        dist, err = float(rng.uniform(1, 20)), float(rng.uniform(-math.pi, math.pi))
        plain, mapped = ctrl.choose_twice(dist, err, p, extra)
        assert plain == ctrl.choose(dist, err, p)
        assert mapped == ctrl.choose(dist, err, with_map(p, extra))
        differ += plain != mapped
    assert differ > 5          # the map changed the choice in some scenes: the test can fail
