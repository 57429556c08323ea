"""The planner's net model: the nominal circle, or the wall the mean current pushes in."""
from __future__ import annotations

import math

import numpy as np
import pytest

from cage_global_rrt.known_map import KnownMap, wall_discs
from cage_global_rrt.planner import plan
from cage_global_rrt.routes import RoutePlanner
from cage_sim.scenarios import Scenario
from cage_sim.world import Obstacle, World

CURRENT = (0.0, -0.3)          # flows towards -y: the wall at +y (upstream) is pushed in


def _world(**kw) -> World:
    return World(30.0, (Obstacle("circle", 0.0, 10.5, 2.0),), (), CURRENT, net_loss=None, **kw)


def test_discs_stay_outside_the_wall_and_cover_the_pushed_in_part():
    net = _world().net
    discs = np.array(wall_discs(net))
    assert len(discs) > 20
    # no disc reaches inside the wall: every point 0.05 m inside it is clear of every disc
    th = np.linspace(0, 2 * math.pi, 720, endpoint=False)
    inner = np.array([net.inward(t, 0.05) for t in th])
    gap = np.hypot(inner[:, None, 0] - discs[None, :, 0], inner[:, None, 1] - discs[None, :, 1]) - discs[None, :, 2]
    assert gap.min() > 0.0
    # the crescent between the real wall and the circle is covered (a point 0.3 m outside the wall
    # where it is pushed in more than 1 m lies in some disc)
    outer = [net.inward(t, -0.3) for t in th if net.radius - float(net.r(t)) > 1.0]
    assert outer
    for x, y in outer:
        assert np.min(np.hypot(x - discs[:, 0], y - discs[:, 1]) - discs[:, 2]) < 0.0


def test_nominal_model_and_calm_water_add_nothing():
    w = _world()
    assert len(KnownMap.from_world(w).circles) == 1
    calm = World(30.0, w.known, (), (0.0, 0.0), net_loss=None)
    assert len(KnownMap.from_world(calm, "current").circles) == 1
    with pytest.raises(ValueError, match="net_model"):
        KnownMap.from_world(w, "tidal")


def test_route_keeps_off_the_pushed_in_wall():
    """Start and goal inside the real wall near the upstream side: the nominal route may leave it, the
    current-aware route keeps the planner's clearance from it all along."""
    w = _world()
    net = w.net
    start, goal = net.inward(math.radians(60), 4.0), net.inward(math.radians(120), 4.0)
    res = plan(KnownMap.from_world(w, "current"), start, goal)
    assert res.ok, res.message
    pts = np.asarray(res.waypoints)[:, :2]
    for a, b in zip(pts[:-1], pts[1:]):
        for s in np.linspace(0, 1, 50):
            x, y = a + s * (b - a)
            assert net.clearance(x, y) >= 1.0 - 1e-6
    # the offline route planner takes the same model
    sc = Scenario("wall", w, tuple(start) + (0.0,), tuple(goal))
    wps = RoutePlanner(net_model="current")(sc)
    assert wps is not None and all(net.clearance(x, y) > 0.9 for x, y in np.asarray(wps)[:, :2])
