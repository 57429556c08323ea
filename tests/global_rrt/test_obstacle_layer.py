"""Obstacle layer: real simulated sonar scans (cage_sim.sonar) confirm, cluster and forget returns,
and a replan on the layer's map avoids what the sonar confirmed."""
from __future__ import annotations

import math

import numpy as np
import pytest

from cage_sim.sonar import make_sonar
from cage_sim.world import Obstacle, World, segment_clearance
from cage_global_rrt import GlobalPlanner, KnownMap, PlannerOptions
from cage_global_rrt.obstacle_layer import LayerParams, ObstacleLayer, plan_with_layer

SONAR = make_sonar("study")
KNOWN = (Obstacle("square", -10.0, 8.0, 2.0),)
UNKNOWN = Obstacle("circle", 0.0, 0.0, 1.5)
WITH = World(30.0, KNOWN, (UNKNOWN,))
WITHOUT = World(30.0, KNOWN, ())
POSE = (-8.0, 0.0, 0.0)


def scan(layer: ObstacleLayer, world: World, pose=POSE) -> None:
    layer.update(pose, SONAR.scan(world, *pose), SONAR.angles, SONAR.max_range)


def layer() -> ObstacleLayer:
    return ObstacleLayer(KnownMap.from_world(WITHOUT))


def test_confirmed_after_enough_scans_only():
    lay = layer()
    for _ in range(LayerParams().confirm_scans - 1):
        scan(lay, WITH)
    assert lay.obstacles() == []
    scan(lay, WITH)
    obs = lay.obstacles()
    assert len(obs) == 1, obs
    ob = obs[0]
    # the circle covers the part of the obstacle the sonar saw and sits on it
    assert math.hypot(ob.x - UNKNOWN.x, ob.y - UNKNOWN.y) < UNKNOWN.size + 0.5
    assert math.hypot(ob.x + 8.0, ob.y) - ob.size <= 8.0 - UNKNOWN.size + 1e-6


def test_known_obstacles_and_net_are_not_added():
    lay = layer()
    for pose in (POSE, (-10.0, 3.0, math.pi / 2), (20.0, 0.0, 0.0)):
        for _ in range(4):
            scan(lay, WITHOUT, pose)
    assert lay.obstacles() == []


def test_forgotten_when_the_sonar_sees_through_it():
    lay = layer()
    for _ in range(4):
        scan(lay, WITH)
    assert lay.obstacles()
    v = lay.version
    for _ in range(LayerParams().forget_scans):
        scan(lay, WITHOUT)
    assert lay.obstacles() == [] and lay.version > v


def test_not_forgotten_while_out_of_view():
    lay = layer()
    for _ in range(4):
        scan(lay, WITH)
    far = (25.0, -10.0, 0.0)   # farther than the sonar's range from the obstacle
    for _ in range(10):
        scan(lay, WITHOUT, far)
    assert len(lay.obstacles()) == 1


def test_replan_on_the_layer_avoids_the_confirmed_return():
    lay = layer()
    for _ in range(4):
        scan(lay, WITH)
    opts = PlannerOptions(planner="optimal")
    goal = (10.0, 0.0)
    blind = GlobalPlanner(KnownMap.from_world(WITHOUT), opts).plan(POSE, goal)
    aware = GlobalPlanner(lay.planning_map(free=(POSE, goal), clearance=1.0), opts).plan(POSE, goal)
    assert blind.ok and aware.ok
    assert segment_clearance(WITH, blind.waypoints, 0.05) < 0        # straight through it
    assert segment_clearance(WITH, aware.waypoints, 0.05) >= 1.0 - 1e-6


def test_replan_next_to_a_confirmed_obstacle_leaves_it_first():
    lay = layer()
    for _ in range(4):
        scan(lay, WITH)
    near = (-2.2, 0.0)           # 0.7 m from the obstacle's surface: inside the layer's margin
    goal = (10.0, 0.5)           # behind it
    planner = GlobalPlanner(KnownMap.from_world(WITHOUT), PlannerOptions(planner="optimal"))
    r = plan_with_layer(planner, lay, near, goal)
    assert r.ok, r.message
    assert np.allclose(r.waypoints[0], near) and np.allclose(r.waypoints[-1], goal)
    d = [WITH.clearance(x, y) for x, y in r.waypoints]
    assert d[1] > d[0]                                                # first it moves away
    assert segment_clearance(WITH, r.waypoints[1:], 0.05) >= 1.0 - 1e-6
    assert len(r.headings) == len(r.waypoints)


def test_layer_that_closes_every_way_falls_back_to_the_known_map():
    """A goal walled in by learnt returns: the plan is made on the known map (as before the
    layer), not refused, and the message says so."""
    lay = layer()
    for _ in range(4):
        scan(lay, WITH)
    ob = lay.obstacles()[0]
    goal = (ob.x + ob.size + 1.2, ob.y)                 # free on the known map, inside the layer's margin
    lay.cells.update({(int(math.floor(goal[0] + dx)), int(math.floor(goal[1] + dy))): _confirmed(goal[0] + dx, goal[1] + dy)
                      for dx, dy in ((2.5, 0.0), (0.0, 2.5), (0.0, -2.5), (2.5, 2.5), (2.5, -2.5))})
    planner = GlobalPlanner(KnownMap.from_world(WITHOUT), PlannerOptions(planner="optimal"))
    r = plan_with_layer(planner, lay, POSE, goal)
    assert r.ok and "known map only" in r.message, r.message


def _confirmed(x, y):
    from cage_global_rrt.obstacle_layer import _Cell
    return _Cell(hits=5, last_hit=1, sx=x, sy=y, n=1)


@pytest.mark.parametrize("bad", [dict(cell=0.0), dict(confirm_scans=0), dict(pad=-1.0), dict(forget_scans=1.5)])
def test_bad_params(bad):
    with pytest.raises(ValueError, match=next(iter(bad))):
        ObstacleLayer(KnownMap.from_world(WITHOUT), LayerParams(**bad))


def test_node_parameters_map_to_layer_params():
    from cage_global_rrt.options import NODE_PARAMETERS, options_from_parameters
    p = LayerParams.from_parameters({**NODE_PARAMETERS, "layer_confirm_scans": 5, "layer_forget_scans": 2})
    assert (p.confirm_scans, p.forget_scans) == (5, 2) and p.error() is None
    assert "confirm_scans" in LayerParams.from_parameters({"layer_confirm_scans": 0}).error()
    # the layer's parameters are the node's, not planner options
    assert options_from_parameters({**NODE_PARAMETERS, "obstacle_layer": True}) == \
        options_from_parameters(dict(NODE_PARAMETERS))


def test_non_finite_pose_is_ignored():
    lay = layer()
    lay.update((math.nan, 0.0, 0.0), SONAR.scan(WITH, *POSE), SONAR.angles, SONAR.max_range)
    assert lay.scans == 0 and not lay.cells
