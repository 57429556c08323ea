"""The global planner's entry points: ``plan(map, start, goal, options)`` and ``GlobalPlanner``.

A request always comes back as a ``PlanResult``: waypoints on success, otherwise a ``PlanStatus``
failure code and a message. Bad input (NaN, a point outside the net, unusable options, something
that is not a map) is reported, never raised, so a ROS callback can publish it as a status.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from .environment import CageEnvironment
from .flyable import fillet
from .geometry import point_valid, polyline_valid, segment_valid
from .known_map import KnownMap, as_known_map
from .lower_bound import VisibilityGraph
from .options import PlannerOptions
from .postprocess import drop_duplicates, headings, path_length, resample, shortcut
from .status import PlanStatus
from .visibility import OptimalGraph, optimal_graph

# Extra clearance (m) for the flyable mode's replans when the arcs of a path do not fit.
FLYABLE_EXTRA = (0.5, 1.0, 1.5, 2.0, 3.0)
# A replanned flyable path may be at most this much longer than the corner path it replaces.
FLYABLE_MAX_DETOUR = 1.25


@dataclass
class PlanResult:
    """Outcome of one request. ``waypoints`` is (N, 2) from start to goal, ``headings`` (N,) the
    direction of travel at each (rad, map frame); both empty on failure."""

    status: PlanStatus
    message: str = ""
    waypoints: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    headings: np.ndarray = field(default_factory=lambda: np.zeros(0))
    raw_path: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    length: float = 0.0
    planning_time: float = 0.0   # whole request, seconds
    solve_time: float = 0.0      # inside OMPL's solve, seconds
    samples: int | None = None   # motion checks = RRT iterations (samples drawn); None for Dubins
    vertices: int | None = None  # tree vertices (only with collect_tree)
    tree: list | None = None     # tree edges ((x0, y0), (x1, y1)) (only with collect_tree)
    planner: str = ""
    flyable: bool | None = None  # flyable mode: True = corners rounded, False = corners kept; None = off
    arcs: list | None = None     # flyable mode: (centre x, centre y, radius) per rounded corner

    @property
    def ok(self) -> bool:
        return self.status == PlanStatus.SUCCESS


class GlobalPlanner:
    """A planner bound to one known map and one set of options, reusing its OMPL environment and
    visibility graph across requests (the node keeps one; the benchmark one per cage)."""

    _kernels_ready = False   # per process: set once the numba kernels are compiled

    def __init__(self, world_or_map=None, options: PlannerOptions | None = None) -> None:
        self.options = options or PlannerOptions()
        self.kmap: KnownMap | None = None
        self._env: CageEnvironment | None = None
        self._graph: VisibilityGraph | None = None
        self._checked: PlannerOptions | None = None
        self._options_error: str | None = None
        if world_or_map is not None:
            self.set_map(world_or_map)

    def set_map(self, world_or_map) -> None:
        """Replace the map (raises TypeError for something that is not a map)."""
        self.kmap = as_known_map(world_or_map)
        self._env = None
        self._graph = None

    def set_options(self, options: PlannerOptions) -> None:
        if options != self.options:
            self.options = options
            self._env = None
            self._graph = None

    def prepare(self) -> None:
        """Build the OMPL setup (sampling planners) or the visibility graph (optimal) and load the
        compiled kernels ahead of the first request."""
        k = self.kmap
        margin = CageEnvironment.check_margin(self.options)
        if self.options.planner == "optimal":
            self.optimal.shortest_path((0.0, 0.0), (0.0, 0.0))
        if self.options.flyable:   # the wider graphs a flyable replan may need, built with the map
            for extra in FLYABLE_EXTRA:
                optimal_graph(k, self.options.clearance + extra)
        if self.options.planner != "optimal":
            self.env  # noqa: B018 - builds it
        pts = np.zeros((2, 2))
        polyline_valid(pts, k.net_radius, margin, k.squares, k.circles)
        point_valid(0.0, 0.0, k.net_radius, margin, k.squares, k.circles)
        segment_valid(0.0, 0.0, 1.0, 0.0, k.net_radius, margin, k.squares, k.circles)
        shortcut(np.zeros((3, 2)), k, margin)
        path_length(headings(resample(np.zeros((2, 2)), 1.0))[:, None].repeat(2, axis=1))

    @property
    def env(self) -> CageEnvironment:
        if self._env is None:
            self._env = CageEnvironment(self.kmap, self.options)
        return self._env

    @property
    def optimal(self) -> OptimalGraph:
        """The shortest-path graph at the clearance (cached by map content across planners)."""
        return optimal_graph(self.kmap, self.options.clearance)

    @property
    def graph(self) -> VisibilityGraph:
        """Visibility graph at the checker's margin (built on first use)."""
        if self._graph is None:
            self._graph = VisibilityGraph(self.kmap, CageEnvironment.check_margin(self.options))
        return self._graph

    def plan(self, start, goal, collect_tree: bool = False) -> PlanResult:
        t0 = time.perf_counter()
        try:
            result = self._plan(start, goal, collect_tree)
        except Exception as err:  # never let a request raise: report it
            result = PlanResult(PlanStatus.NO_VALID_PATH, f"planner error: {type(err).__name__}: {err}")
        result.planning_time = time.perf_counter() - t0
        result.planner = self.options.planner
        return result

    def _plan(self, start, goal, collect_tree: bool) -> PlanResult:
        if self.kmap is None:
            return PlanResult(PlanStatus.NO_MAP, "no map set")
        if self._checked is not self.options:   # options are frozen: validate each object once
            self._options_error, self._checked = self.options.error(), self.options
        err = self._options_error
        if err:
            return PlanResult(PlanStatus.INVALID_INPUT, f"options: {err}")
        s, g = parse_pose(start, "start"), parse_pose(goal, "goal")
        for p in (s, g):
            if isinstance(p, str):
                return PlanResult(PlanStatus.INVALID_INPUT, p)
        bad = self._endpoint_failure(s, g)
        if bad:
            return bad
        if not GlobalPlanner._kernels_ready:
            # Compile (or load from numba's cache) the kernels before the clock of the solve starts: in a
            # fresh checkout the first compilation takes seconds and would eat the time limit.
            self.prepare()
            GlobalPlanner._kernels_ready = True
        if self.options.planner == "optimal":
            t0 = time.perf_counter()
            length, pts = self.optimal.shortest_path(s, g)
            base = dict(raw_path=pts.copy(), solve_time=time.perf_counter() - t0)
            if not math.isfinite(length):
                return PlanResult(PlanStatus.NO_VALID_PATH, "goal not reachable from start on the known map "
                                                            f"with {self.options.clearance:g} m clearance", **base)
            return self._finish(pts, None, base, s, g)
        env = self.env
        start_yaw = s[2] if len(s) > 2 else math.atan2(g[1] - s[1], g[0] - s[0])
        goal_yaw = g[2] if len(g) > 2 else math.atan2(g[1] - s[1], g[0] - s[0])
        out = env.solve(s[:2], g[:2], start_yaw, goal_yaw, collect_tree)
        base = dict(raw_path=out.states[:, :2].copy(), solve_time=out.solve_time, samples=out.samples,
                    vertices=out.vertices, tree=out.tree)
        if not out.exact:
            return self._failure(s, g, out.ompl_status, base)
        if env.dubins:
            dense = drop_duplicates(env.dubins_polyline(self.options.waypoint_spacing))
            return self._finish(dense[:, :2], dense[:, 2], base, s, g)
        pts = shortcut(out.states, self.kmap, env.margin) if self.options.simplify else out.states
        return self._finish(pts, None, base, s, g)

    def _finish(self, pts: np.ndarray, yaw: np.ndarray | None, base: dict, s, g) -> PlanResult:
        """Round the corners (flyable mode), resample, check the clearance once more, report."""
        o, k = self.options, self.kmap
        extra = {}
        if o.flyable:
            pts, arcs, complete, note = self._flyable(pts, s, g)
            extra = dict(flyable=complete, arcs=arcs)
        if yaw is None:
            pts = resample(pts, o.waypoint_spacing)
            yaw = headings(pts)
        pts = np.ascontiguousarray(pts, dtype=np.float64)
        if not polyline_valid(pts, k.net_radius, o.clearance - 1e-9, k.squares, k.circles):
            return PlanResult(PlanStatus.NO_VALID_PATH, "post-processed path failed the clearance check", **base)
        length = path_length(pts)
        msg = f"{len(pts)} waypoints, {length:.2f} m" + (note if o.flyable else "")
        return PlanResult(PlanStatus.SUCCESS, msg, pts, yaw, length=length, **base, **extra)

    def _flyable(self, pts: np.ndarray, s, g):
        """(points, arcs, every corner rounded?, message suffix): the path's corners rounded; else a
        path replanned with more clearance (at most FLYABLE_MAX_DETOUR longer) whose corners can all
        be rounded; else the path with every corner that fits rounded and the others kept sharp;
        else the corner path."""
        o, k = self.options, self.kmap
        done = fillet(pts, k, o.clearance, o.turning_radius, o.arc_spacing)
        if done is None:
            limit = path_length(pts) * FLYABLE_MAX_DETOUR
            for extra in FLYABLE_EXTRA:
                length, alt = optimal_graph(k, o.clearance + extra).shortest_path(s, g, endpoint_margin=o.clearance)
                if length > limit:
                    break   # wider graphs only get longer: a long detour is worse than a sharp corner
                done = fillet(alt, k, o.clearance, o.turning_radius, o.arc_spacing)
                if done is not None:
                    break
        if done is not None:
            return done[0], done[1], True, f", {len(done[1])} arcs of radius {o.turning_radius:g} m"
        part = fillet(pts, k, o.clearance, o.turning_radius, o.arc_spacing, keep_sharp=True) or \
            fillet(pts, k, o.clearance, o.turning_radius, o.arc_spacing, keep_sharp=True, merge=False)
        if part is not None:
            return part[0], part[1], False, (f", {len(part[1])} arcs of radius {o.turning_radius:g} m; "
                                             f"{part[2]} corner(s) kept sharp: no arc fits there with the clearance")
        return pts, [], False, (f"; corners kept: no arcs of radius {o.turning_radius:g} m fit with the "
                                f"clearance within {FLYABLE_MAX_DETOUR:g}x the length")

    def _endpoint_failure(self, s, g) -> PlanResult | None:
        """Nav2-style start/goal codes: outside the net, or inside an inflated obstacle/net margin."""
        k, margin = self.kmap, CageEnvironment.check_margin(self.options)
        for p, name, outside, occupied in ((s, "start", PlanStatus.START_OUTSIDE_NET, PlanStatus.START_OCCUPIED),
                                           (g, "goal", PlanStatus.GOAL_OUTSIDE_NET, PlanStatus.GOAL_OCCUPIED)):
            r = math.hypot(p[0], p[1])
            if r > k.net_radius:
                return PlanResult(outside, f"{name} ({p[0]:.2f}, {p[1]:.2f}) is {r - k.net_radius:.2f} m "
                                           f"outside the net (radius {k.net_radius:g} m)")
            if not point_valid(p[0], p[1], k.net_radius, margin, k.squares, k.circles):
                return PlanResult(occupied, f"{name} ({p[0]:.2f}, {p[1]:.2f}) is closer than the "
                                            f"clearance {margin:.2f} m to an obstacle or the net")
        return None

    def _failure(self, s, g, ompl_status: str, base: dict) -> PlanResult:
        """No exact solution in time: NO_VALID_PATH when the visibility graph proves start and goal
        disconnected, otherwise TIMEOUT."""
        if math.isinf(self.graph.shortest(s, g)):
            return PlanResult(PlanStatus.NO_VALID_PATH, "goal not reachable from start on the known map "
                                                        f"with {self.options.clearance:g} m clearance", **base)
        return PlanResult(PlanStatus.TIMEOUT, f"no path within {self.options.time_limit:g} s "
                                              f"(OMPL: {ompl_status})", **base)


def parse_pose(p, name: str):
    """(x, y) or (x, y, yaw) as a tuple of finite floats, or an error message."""
    try:
        vals = tuple(float(v) for v in p)
    except (TypeError, ValueError):
        return f"{name}: expected (x, y) or (x, y, yaw) numbers, got {p!r}"
    if len(vals) not in (2, 3):
        return f"{name}: expected 2 or 3 numbers, got {len(vals)}"
    if not all(math.isfinite(v) for v in vals):
        return f"{name}: coordinates must be finite, got {vals}"
    return vals


def plan(world_or_map, start, goal, options: PlannerOptions | None = None,
         collect_tree: bool = False) -> PlanResult:
    """One-shot plan on a World or KnownMap (builds the OMPL setup; reuse a GlobalPlanner for many)."""
    t0 = time.perf_counter()
    try:
        planner = GlobalPlanner(world_or_map, options)
    except TypeError as err:
        return PlanResult(PlanStatus.NO_MAP if world_or_map is None else PlanStatus.INVALID_INPUT, str(err),
                          planning_time=time.perf_counter() - t0)
    return planner.plan(start, goal, collect_tree)
