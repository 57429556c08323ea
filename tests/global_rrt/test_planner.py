"""Global planner core: clearance, failure codes, determinism, Dubins turns, every option.

Real OMPL, small time limits; the whole file runs in seconds."""
from __future__ import annotations

import math

import numpy as np
import pytest

from cage_sim.scenarios import generate_cage
from cage_sim.world import Obstacle, World, segment_clearance
from cage_global_rrt import (PLANNERS, GlobalPlanner, KnownMap, PlannerOptions, PlanStatus,
                             VisibilityGraph, plan, shortest_path_lower_bound)
from cage_global_rrt.postprocess import resample

FAST = PlannerOptions(time_limit=0.5, seed=7)


def cage(seed: int):
    return generate_cage(np.random.default_rng(seed))


def enclosed_world() -> World:
    """A closed ring of touching 2 m squares around the origin (free pocket inside)."""
    ring = [(x, y) for x in (-4, -2, 0, 2, 4) for y in (-4, 4)] + [(x, y) for x in (-4, 4) for y in (-2, 0, 2)]
    return World(30.0, tuple(Obstacle("square", x, y, 2.0) for x, y in ring))


def min_turn_radius(p: np.ndarray) -> float:
    """Smallest circumradius of three consecutive waypoints (inf on straight runs)."""
    a, b, c = p[:-2], p[1:-1], p[2:]
    ab, bc, ca = np.hypot(*(b - a).T), np.hypot(*(c - b).T), np.hypot(*(a - c).T)
    cross = np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
    with np.errstate(divide="ignore"):
        r = np.where(cross > 1e-9, ab * bc * ca / (2.0 * cross), np.inf)
    return float(r.min())


# ----------------------------------------------------------------------------- clearance

@pytest.mark.parametrize("seed", range(8))
def test_plan_keeps_clearance_on_fine_resampling(seed):
    sc = cage(seed)
    opts = FAST.with_(seed=seed + 1)
    r = plan(sc.world, sc.start, sc.goal, opts)
    assert r.status == PlanStatus.SUCCESS, r.message
    assert np.allclose(r.waypoints[0], sc.start[:2]) and np.allclose(r.waypoints[-1], sc.goal)
    known = sc.world.known_map()
    assert segment_clearance(known, r.waypoints, resolution=0.02) >= opts.clearance - 1e-6
    assert segment_clearance(known, r.raw_path, resolution=0.02) >= opts.clearance - 1e-6
    steps = np.hypot(*np.diff(r.waypoints, axis=0).T)
    assert steps.max() <= opts.waypoint_spacing + 1e-9
    assert len(r.headings) == len(r.waypoints)


def test_plan_uses_only_the_known_map():
    sc = cage(3)
    r = plan(sc.world, sc.start, sc.goal, FAST)
    assert r.ok
    only_known = plan(sc.world.known_map(), sc.start, sc.goal, FAST)
    assert np.array_equal(r.waypoints, only_known.waypoints)


def test_corner_cutting_is_impossible():
    """A segment whose endpoints both clear a square but that clips its corner is rejected."""
    world = World(30.0, (Obstacle("square", 0.0, 0.0, 2.0),))
    r = plan(world, (-3.0, 1.5), (1.5, -3.0), FAST.with_(clearance=0.5))
    assert r.ok
    assert segment_clearance(world, r.waypoints, resolution=0.01) >= 0.5 - 1e-6


# ----------------------------------------------------------------------------- failure codes

@pytest.mark.parametrize("start,goal,code", [
    ((0.0, 0.0), (10.0, 0.0), PlanStatus.START_OCCUPIED),       # inside the square at the origin
    ((1.6, 0.0), (10.0, 0.0), PlanStatus.START_OCCUPIED),       # outside it, but within the clearance
    ((29.5, 0.0), (10.0, 0.0), PlanStatus.START_OCCUPIED),      # inside the net, within its margin
    ((31.0, 0.0), (10.0, 0.0), PlanStatus.START_OUTSIDE_NET),
    ((10.0, 0.0), (0.0, 0.5), PlanStatus.GOAL_OCCUPIED),
    ((10.0, 0.0), (0.0, -40.0), PlanStatus.GOAL_OUTSIDE_NET),
    ((math.nan, 0.0), (10.0, 0.0), PlanStatus.INVALID_INPUT),
    ((10.0, 0.0), (math.inf, 0.0), PlanStatus.INVALID_INPUT),
    ((10.0,), (10.0, 0.0), PlanStatus.INVALID_INPUT),
    ("here", (10.0, 0.0), PlanStatus.INVALID_INPUT),
    (None, (10.0, 0.0), PlanStatus.INVALID_INPUT),
])
def test_bad_endpoints_get_their_code(start, goal, code):
    world = World(30.0, (Obstacle("square", 0.0, 0.0, 2.0),))
    r = plan(world, start, goal, FAST)
    assert r.status == code, r.message
    assert r.message and len(r.waypoints) == 0


@pytest.mark.parametrize("bad", [dict(planner="prm"), dict(max_step=0.0), dict(max_step=math.nan),
                                 dict(clearance=-1.0), dict(time_limit=0.0), dict(goal_bias=1.5), dict(goal_bias=0.0),
                                 dict(seed=0), dict(seed=1.5), dict(turning_radius=-2.0),
                                 dict(waypoint_spacing=math.inf), dict(dubins="yes")])
def test_bad_options_are_invalid_input(bad):
    r = plan(cage(0).world, cage(0).start, cage(0).goal, FAST.with_(**bad))
    assert r.status == PlanStatus.INVALID_INPUT
    assert r.message.startswith("options:")


def test_no_map_and_not_a_map():
    assert plan(None, (0, 0), (1, 1)).status == PlanStatus.NO_MAP
    assert GlobalPlanner().plan((0, 0), (1, 1)).status == PlanStatus.NO_MAP
    assert plan("map", (0, 0), (1, 1)).status == PlanStatus.INVALID_INPUT


def test_enclosed_goal_is_no_valid_path():
    r = plan(enclosed_world(), (15.0, 0.0), (0.0, 0.0), FAST.with_(time_limit=0.05))
    assert r.status == PlanStatus.NO_VALID_PATH, r.message
    assert r.solve_time < 0.5


def test_too_little_time_is_timeout():
    world = World(30.0, (Obstacle("square", 0.0, 0.0, 8.0),))
    r = plan(world, (-10.0, 0.0), (10.0, 0.0), FAST.with_(time_limit=1e-6))
    assert r.status == PlanStatus.TIMEOUT, r.message


# ----------------------------------------------------------------------------- determinism

def test_same_seed_same_waypoints():
    sc = cage(11)
    a = GlobalPlanner(sc.world, FAST.with_(seed=42))
    b = GlobalPlanner(sc.world, FAST.with_(seed=42))
    other = GlobalPlanner(sc.world, FAST.with_(seed=43))
    first = a.plan(sc.start, sc.goal)
    other.plan(sc.start, sc.goal)          # interleaved use of OMPL's RNG must not matter
    again = a.plan(sc.start, sc.goal)
    fresh = b.plan(sc.start, sc.goal)
    assert first.ok and again.ok and fresh.ok
    assert np.array_equal(first.raw_path, again.raw_path) and np.array_equal(first.raw_path, fresh.raw_path)
    assert np.array_equal(first.waypoints, fresh.waypoints)
    assert first.samples == fresh.samples


def test_different_seeds_explore_differently():
    sc = cage(11)
    raws = {plan(sc.world, sc.start, sc.goal, FAST.with_(seed=s, simplify=False)).raw_path.tobytes()
            for s in (1, 2, 3, 4)}
    assert len(raws) > 1


# ----------------------------------------------------------------------------- Dubins

@pytest.mark.parametrize("seed", [1, 4])
def test_dubins_respects_turning_radius(seed):
    sc = cage(seed)
    heading_away = math.atan2(sc.start[1] - sc.goal[1], sc.start[0] - sc.goal[0])
    opts = FAST.with_(dubins=True, waypoint_spacing=0.25, time_limit=1.0, seed=seed)
    r = plan(sc.world, (sc.start[0], sc.start[1], heading_away), sc.goal, opts)
    assert r.ok, r.message
    assert min_turn_radius(r.waypoints) >= opts.turning_radius * (1 - 1e-3)
    assert abs(math.remainder(r.headings[0] - heading_away, 2 * math.pi)) < 1e-6
    assert segment_clearance(sc.world.known_map(), r.waypoints, 0.02) >= opts.clearance - 1e-6
    assert r.length > math.dist(sc.start[:2], sc.goal)  # it had to turn around


def test_dubins_goal_heading_is_honoured():
    world = World(30.0, ())
    r = plan(world, (-10.0, 0.0, 0.0), (10.0, 0.0, math.pi / 2), FAST.with_(dubins=True, waypoint_spacing=0.5))
    assert r.ok
    assert abs(math.remainder(r.headings[-1] - math.pi / 2, 2 * math.pi)) < 1e-6


# ----------------------------------------------------------------------------- every option

@pytest.mark.parametrize("planner", PLANNERS)
def test_every_planner_succeeds(planner):
    sc = cage(5)
    opts = FAST.with_(planner=planner, time_limit=0.1 if "star" in planner else 0.5)
    r = plan(sc.world, sc.start, sc.goal, opts)
    assert r.ok, r.message
    assert r.planner == planner
    assert segment_clearance(sc.world.known_map(), r.waypoints, 0.02) >= opts.clearance - 1e-6


@pytest.mark.parametrize("change", [dict(simplify=False), dict(waypoint_spacing=0.0), dict(goal_bias=0.5),
                                    dict(max_step=12.0), dict(max_step=7.0), dict(clearance=0.0),
                                    dict(clearance=1.5), dict(seed=None), dict(dubins=True, simplify=False)])
def test_option_variants(change):
    sc = cage(6)
    opts = FAST.with_(**change)
    r = plan(sc.world, sc.start, sc.goal, opts)
    assert r.ok, r.message
    assert segment_clearance(sc.world.known_map(), r.waypoints, 0.02) >= opts.clearance - 1e-6
    if change.get("waypoint_spacing") == 0.0:
        assert len(r.waypoints) <= len(r.raw_path)


def test_simplify_shortens():
    sc = cage(8)
    raw = plan(sc.world, sc.start, sc.goal, FAST.with_(simplify=False))
    short = plan(sc.world, sc.start, sc.goal, FAST)
    assert short.length <= raw.length + 1e-9


def test_collect_tree_reports_vertices_and_samples():
    sc = cage(2)
    r = plan(sc.world, sc.start, sc.goal, FAST, collect_tree=True)
    assert r.vertices and r.vertices >= 2 and len(r.tree) == r.vertices - 1
    assert r.samples >= r.vertices - 1


# ----------------------------------------------------------------------------- helpers

def test_lower_bound_is_below_every_plan():
    for seed in range(5):
        sc = cage(seed)
        g = VisibilityGraph(KnownMap.from_world(sc.world), 1.0)
        lb = g.shortest(sc.start, sc.goal)
        r = plan(sc.world, sc.start, sc.goal, FAST.with_(planner="rrtstar", time_limit=0.2))
        assert math.dist(sc.start[:2], sc.goal) - 1e-9 <= lb <= r.length + 1e-6


def test_lower_bound_straight_and_enclosed():
    km = KnownMap.from_world(World(30.0, (Obstacle("square", 0.0, 10.0, 2.0),)))
    assert shortest_path_lower_bound(km, (-5, 0), (5, 0), 1.0) == pytest.approx(10.0)
    around = shortest_path_lower_bound(km, (-5, 10), (5, 10), 1.0)
    assert 10.0 < around < 10.0 + 2 * 2.0
    assert math.isinf(shortest_path_lower_bound(KnownMap.from_world(enclosed_world()), (15, 0), (0, 0), 1.0))


def test_resample_spacing():
    pts = resample(np.array([[0.0, 0.0], [3.5, 0.0], [3.5, 2.0]]), 1.0)
    steps = np.hypot(*np.diff(pts, axis=0).T)
    assert steps.max() <= 1.0 + 1e-12 and [3.5, 0.0] in pts.tolist()


def test_dubins_same_seed_same_waypoints():
    sc = cage(4)
    opts = FAST.with_(dubins=True, seed=9, time_limit=1.0)
    first = GlobalPlanner(sc.world, opts).plan(sc.start, sc.goal)
    GlobalPlanner(sc.world, opts.with_(seed=3)).plan(sc.start, sc.goal)
    again = GlobalPlanner(sc.world, opts).plan(sc.start, sc.goal)
    assert first.ok and np.array_equal(first.waypoints, again.waypoints)
