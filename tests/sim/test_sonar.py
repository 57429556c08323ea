"""Sonar ray casting against analytic answers."""
import math

import numpy as np
import pytest

from cage_sim.sonar import SonarModel
from cage_sim.world import Obstacle, World


def beam(sonar: SonarModel, deg: float) -> int:
    return int(round(math.radians(deg) / sonar.angle_increment))


def test_net_from_centre_and_off_centre():
    w = World(net_radius=10.0)
    s = SonarModel(max_range=50.0)
    r = s.scan(w, 0.0, 0.0, 0.3)
    assert np.allclose(r, 10.0)
    # From (6, 0) facing +x: 4 m ahead, 16 m behind; sideways sqrt(100 - 36) = 8 m.
    r = s.scan(w, 6.0, 0.0, 0.0)
    assert r[beam(s, 0)] == pytest.approx(4.0)
    assert r[beam(s, 180)] == pytest.approx(16.0)
    assert r[beam(s, 90)] == pytest.approx(8.0)


def test_beams_are_in_body_frame():
    w = World(30.0, (Obstacle("square", 0.0, 5.0, 2.0),))
    s = SonarModel()
    # Facing +y, the square (near face at y = 4) is straight ahead: beam 0.
    r = s.scan(w, 0.0, 0.0, math.pi / 2)
    assert r[0] == pytest.approx(4.0)
    assert r[beam(s, 270)] == pytest.approx(20.0) or math.isinf(r[beam(s, 270)])


def test_square_and_circle_exact():
    w = World(30.0, (Obstacle("square", 5.0, 0.0, 2.0),), (Obstacle("circle", 0.0, -6.0, 1.5),))
    s = SonarModel()
    r = s.scan(w, 0.0, 0.0, 0.0)
    assert r[beam(s, 0)] == pytest.approx(4.0)
    assert r[beam(s, 270)] == pytest.approx(4.5)
    # 10 deg off the square's axis: the ray meets its near face x = 4 at 4 / cos(10 deg).
    assert r[beam(s, 10)] == pytest.approx(4.0 / math.cos(math.radians(10)))
    # A beam grazing the circle: offset angle such that the ray is tangent-ish still hits exactly.
    a = math.radians(-90 + 10)
    d = np.array([math.cos(a), math.sin(a)])
    b = np.dot(np.array([0.0, -6.0]), d)
    t = b - math.sqrt(b * b - (36 - 1.5 ** 2))
    assert r[beam(s, 280)] == pytest.approx(t)


def test_out_of_range_is_inf_and_inside_is_zero():
    w = World(100.0, (Obstacle("circle", 0.0, 0.0, 1.0),))
    s = SonarModel(max_range=20.0)
    assert np.all(np.isinf(s.scan(w, 50.0, 0.0, math.pi)[1:35]))  # looking away from everything
    assert np.all(s.scan(w, 0.2, 0.0, 0.0) == 0.0)                 # inside the obstacle
    assert np.all(s.scan(World(5.0), 6.0, 0.0, 0.0) == 0.0)        # outside the net


def test_batch_matches_single_over_many_worlds():
    rng = np.random.default_rng(1)
    s = SonarModel()
    worlds, poses = [], []
    for _ in range(12):
        obs = [Obstacle(rng.choice(["square", "circle"]), *rng.uniform(-20, 20, 2), rng.uniform(0.5, 2))
               for _ in range(int(rng.integers(0, 15)))]
        worlds.append(World(30.0, tuple(obs[:5]), tuple(obs[5:])))
        poses.append((*rng.uniform(-15, 15, 2), rng.uniform(-3, 3)))
    batch = s.scan_batch(worlds, np.array(poses))
    for w, p, row in zip(worlds, poses, batch):
        assert np.array_equal(row, s.scan(w, *p))
    one_world = s.scan_batch([worlds[0]], np.array(poses))
    assert np.array_equal(one_world[3], s.scan(worlds[0], *poses[3]))


def test_moving_obstacle_is_scanned_where_it_is_at_t():
    ob = Obstacle("circle", 5.0, 0.0, 1.0, ax=0.0, ay=3.0, period=40.0)
    w = World(30.0, (), (ob,))
    s = SonarModel()
    assert s.scan(w, 0.0, 0.0, 0.0, t=0.0)[0] == pytest.approx(4.0)
    assert math.isinf(s.scan(w, 0.0, 0.0, 0.0, t=10.0)[0]) or s.scan(w, 0, 0, 0, t=10.0)[0] > 15


def test_noise_and_dropout_are_seeded():
    w = World(10.0)
    s = SonarModel(noise_std=0.1, dropout=0.2)
    a = s.scan(w, 0, 0, 0, rng=np.random.default_rng(3))
    b = s.scan(w, 0, 0, 0, rng=np.random.default_rng(3))
    assert np.array_equal(a, b)
    assert np.isinf(a).sum() > 3 and np.isfinite(a).sum() > 40
    assert abs(float(np.mean(a[np.isfinite(a)])) - 10.0) < 0.1
    assert np.array_equal(s.scan(w, 0, 0, 0), np.full(72, 10.0))   # no rng: the exact scan
