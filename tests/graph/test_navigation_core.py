"""The navigator's ROS-free part: result codes, goal checks with the planner's validity test, progress."""
from __future__ import annotations

import math

import numpy as np
import pytest

from cage_global_rrt.geometry import point_valid
from cage_global_rrt.known_map import KnownMap
from cage_sim import navigation
from cage_sim.navigation import MissionProgress, goal_problem
from cage_sim.scenarios import draw_scenario


def test_result_codes_are_the_action_files():
    from cage_planner_msgs.action import Navigate
    names = [n for n in dir(Navigate.Result) if n.isupper()]
    assert len(names) == len(navigation.CODE_NAMES) == 8
    for name in names:
        assert getattr(navigation, name) == getattr(Navigate.Result, name), name


def test_goal_problem_uses_the_planners_validity_and_names_the_reason():
    sc = draw_scenario("full_cage", 0)
    k = KnownMap.from_world(sc.world)
    check = lambda g: goal_problem(g, k.net_radius, 1.0, k.squares, k.circles, point_valid)  # noqa: E731
    assert check(sc.goal) is None
    ob = sc.world.known[0]
    code, why = check((ob.x, ob.y))
    assert code == "GOAL_OCCUPIED" and "clearance" in why
    code, why = check((40.0, 0.0))
    assert code == "GOAL_OUTSIDE_NET" and "10.00 m outside" in why
    assert check((29.5, 0.0))[0] == "GOAL_OCCUPIED"            # inside the net, within the clearance of it
    assert check((math.nan, 0.0))[0] == "INVALID_INPUT"


def test_progress_counts_distance_decisions_and_shield():
    p = MissionProgress(1, (10.0, 0.0))
    p.set_route(np.array([[5.0, 5.0], [10.0, 0.0]]), (0.0, 0.0, 0.0))
    assert p.path_length == pytest.approx(2 * math.hypot(5, 5))
    p.start(2_000_000_000, (0.0, 0.0, 0.0))
    p.on_pose(3_000_000_000, (1.0, 1.0, 0.0))
    for k, shielded in ((2, False), (3, True), (3, True), (4, False)):   # a repeated setpoint counts once
        p.on_setpoint(k, shielded)
    assert len(p.decisions) == 3 and len(p.shielded) == 1
    assert p.travelled == pytest.approx(math.sqrt(2))
    assert p.distance_remaining() == pytest.approx(math.hypot(4, 4) + math.hypot(5, 5))
    assert p.elapsed_ns == 1_000_000_000


def test_progress_with_the_known_map_measures_the_goal_in_sight_as_the_judge():
    # navigator_node's feedback: the same route tracker as the judge's (route.RouteTracker). Pushed
    # off to (4, 15), nearer the goal than the corner, with the known map clear on the way, the
    # distance left is the straight way to the goal, with the map arriving before or after the route.
    from cage_sim.map_points import MapPoints
    from cage_sim.world import World
    route, off = np.array([[0.0, 20.0], [6.0, 20.0]]), (4.0, 15.0, 0.0)
    clear = MapPoints.from_world(World(30.0))
    plain = MissionProgress(1, (6.0, 20.0))
    plain.set_route(route, (0.0, 0.0, 0.0))
    plain.on_pose(1, off)
    assert plain.distance_remaining() == pytest.approx(math.hypot(4, 5) + 6.0)      # round the corner
    for before in (True, False):
        p = MissionProgress(1, (6.0, 20.0), known=clear if before else None)
        p.set_route(route, (0.0, 0.0, 0.0))
        if not before:
            p.set_known(clear)
        p.on_pose(1, off)
        assert p.distance_remaining() == pytest.approx(math.hypot(2, 5)), before     # straight to the goal
        assert p.tracker.sighted


def test_free_domain_sees_a_participant(probe, ros_env):
    """run_mission.sh's domain check: a domain with a participant on it (the probe's) is not free."""
    import importlib.util
    from graph_testlib import ROOT
    spec = importlib.util.spec_from_file_location("free_domain", ROOT / "scripts" / "free_domain.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    assert mod.others_on(int(ros_env["ROS_DOMAIN_ID"]), 1.0) >= 1
