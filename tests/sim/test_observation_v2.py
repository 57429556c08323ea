"""Observation v2 and the memory: re-projection, v1 unchanged, compatibility by field, gym checks."""
import math

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from cage_sim.env import CageNavEnv
from cage_sim.memory import ReturnMemory
from cage_sim.mission import EnvConfig, Mission, observe_batch
from cage_sim.observation import (LAYOUT_NAME, ObservationBuilder, ObservationLayout, ObservationLayoutV2,
                                  layout_from_dict)
from cage_sim.scenarios import draw_scenario
from cage_sim.sonar import make_sonar


def test_v1_layout_is_unchanged():
    lay = EnvConfig().layout
    assert isinstance(lay, ObservationLayout)
    assert lay.to_dict() == {"name": LAYOUT_NAME, "n_beams": 72, "max_range": 20.0, "waypoint_scale": 20.0}
    obs = lay.build(np.r_[np.full(71, np.inf), 10.0], 10.0, math.pi / 2)
    assert obs.shape == (74,) and obs[70] == 1.0 and obs[71] == 0.5 and obs[72] == 0.5 and obs[73] == 0.5
    assert layout_from_dict(lay.to_dict()) == lay


def test_memory_reprojects_returns_into_the_body_frame():
    mem = ReturnMemory(bins=72, horizon=5.0)
    # seen dead ahead, 4 m away, from the origin facing +x: a point at (4, 0)
    mem.add(np.array([4.0]), np.array([0.0]), np.array([[0.0, 0.0, 0.0]]), np.array([0.0]))
    h = mem.histogram(2.0, 0.0, math.pi / 2)      # moved 2 m ahead, turned left: it is 2 m to the right
    assert h[54] == pytest.approx(2.0) and np.isinf(np.delete(h, 54)).all()   # bin 54 = 270 deg
    assert mem.body_points(2.0, 0.0, math.pi / 2) == pytest.approx(np.array([[0.0, -2.0]]))
    mem.prune(4.9)
    assert len(mem) == 1
    mem.prune(5.1)
    assert len(mem) == 0


def test_an_fls_policy_remembers_what_left_its_sector():
    cfg = EnvConfig(sonar=make_sonar("fls", noise_std=0.0, dropout=0.0), memory_bins=72)
    b = ObservationBuilder(cfg.layout)
    lay = cfg.layout
    ranges = np.full(64, np.inf)
    ranges[32] = 5.0                                   # something 5 m ahead
    b.build(ranges, 0.0, 0.0, 0.0, 0.0, 10.0, 0.0)
    obs = b.build(np.full(64, np.inf), 0.0, 0.0, math.pi, 1.0, 10.0, 0.0)   # turned round: FLS sees nothing
    assert np.all(lay.ranges_from(obs) == 20.0)
    mem = lay.memory_from(obs)
    assert mem[36] == pytest.approx(5.0 * math.cos(lay.angles[32]), abs=0.3)   # now behind


def test_compatibility_check_names_the_sensor_profile():
    fls = EnvConfig(sonar="fls").layout
    study = EnvConfig(sonar="study", velocity=True).layout
    assert isinstance(fls, ObservationLayoutV2) and isinstance(study, ObservationLayoutV2)
    with pytest.raises(ValueError, match="profile: file has 'fls', this build uses 'study'"):
        study.check_compatible(fls.to_dict())
    with pytest.raises(ValueError, match="profile: file has 'study', this build uses 'fls'"):
        fls.check_compatible(EnvConfig().layout.to_dict())       # a v1 file is a study policy
    fls.check_compatible(layout_from_dict(fls.to_dict()).to_dict())


def test_empty_scan_is_a_valid_observation():
    for cfg in (EnvConfig(), EnvConfig(sonar="fls", velocity=True, memory_bins=36)):
        lay = cfg.layout
        n = lay.n_beams
        b = ObservationBuilder(lay)
        obs = b.build(np.full(n, np.inf), 0.0, 0.0, 0.0, 0.0, 10.0, 0.0, v_ground=(1.0, 0.0))
        space = CageNavEnv("cage", cfg).observation_space
        assert space.contains(obs) and np.all(lay.ranges_from(obs) == 20.0)


@pytest.mark.parametrize("cfg", [
    EnvConfig(sonar="multibeam360"), EnvConfig(sonar="fls", velocity=True, memory_bins=72),
    EnvConfig(sonar="scanning", memory_bins=72, scan_in_obs=False),
])
def test_profiles_pass_gymnasium_check_env_and_report_success(cfg):
    env = CageNavEnv("cage?current=0.25&schools=2", cfg)
    check_env(env, skip_render_check=True)
    obs, _ = env.reset(seed=2)
    assert obs.shape == (cfg.layout.size,)
    _, _, _, _, info = env.step(np.zeros(1, dtype=np.float32))
    assert info["is_success"] is False and "outcome" in info


def test_batched_observation_equals_the_single_env_for_v2():
    cfg = EnvConfig(sonar=make_sonar("fls", noise_std=0.0, dropout=0.0), velocity=True, memory_bins=36)
    sc = draw_scenario("cage?current=0.25", 4)
    a, b = Mission(sc, cfg), Mission(sc, cfg)
    for action in (0.0, 0.5, -1.0):
        one = a.observe(a.sense())
        two = observe_batch(cfg, [b])[0]
        assert np.array_equal(one, two)
        a.step(action)
        b.step(action)


def test_memory_and_scanning_head_start_over_when_time_goes_back():
    cfg = EnvConfig(sonar="fls", memory_bins=36)
    b = ObservationBuilder(cfg.layout)
    r = np.full(64, np.inf)
    r[32] = 5.0
    b.build(r, 0.0, 0.0, 0.0, 10.0, 10.0, 0.0)
    assert len(b.memory) == 1
    b.build(np.full(64, np.inf), 0.0, 0.0, 0.0, 0.0, 10.0, 0.0)     # a new mission at t = 0
    assert len(b.memory) == 0
    from cage_sim.world import World
    s = make_sonar("scanning")
    head = s.head()
    head.reset(World(10.0), 0.0, 0.0, 0.0, 50.0)
    scan = head.update(World(10.0), 0.0, 0.0, 0.0, 0.0)
    assert scan.new.all() and scan.stamps.max() == pytest.approx(0.0)
