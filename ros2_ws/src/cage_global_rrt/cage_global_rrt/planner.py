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
from .geometry import point_valid, polyline_valid, segment_valid
from .known_map import KnownMap, as_known_map
from .lower_bound import VisibilityGraph
from .options import PlannerOptions
from .postprocess import drop_duplicates, headings, path_length, resample, shortcut
from .status import PlanStatus


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
        """Build the OMPL setup and load the compiled kernels ahead of the first request."""
        env = self.env
        k = self.kmap
        pts = np.zeros((2, 2))
        polyline_valid(pts, k.net_radius, env.margin, k.squares, k.circles)
        point_valid(0.0, 0.0, k.net_radius, env.margin, k.squares, k.circles)
        segment_valid(0.0, 0.0, 1.0, 0.0, k.net_radius, env.margin, k.squares, k.circles)
        shortcut(np.zeros((3, 2)), k, env.margin)

    @property
    def env(self) -> CageEnvironment:
        if self._env is None:
            self._env = CageEnvironment(self.kmap, self.options)
        return self._env

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
        err = self.options.error()
        if err:
            return PlanResult(PlanStatus.INVALID_INPUT, f"options: {err}")
        s, g = parse_pose(start, "start"), parse_pose(goal, "goal")
        for p in (s, g):
            if isinstance(p, str):
                return PlanResult(PlanStatus.INVALID_INPUT, p)
        bad = self._endpoint_failure(s, g)
        if bad:
            return bad
        env = self.env
        if not GlobalPlanner._kernels_ready:
            # Compile (or load from numba's cache) the kernels before the clock of the solve starts: in a
            # fresh checkout the first compilation takes seconds and would eat the time limit.
            self.prepare()
            GlobalPlanner._kernels_ready = True
        start_yaw = s[2] if len(s) > 2 else math.atan2(g[1] - s[1], g[0] - s[0])
        goal_yaw = g[2] if len(g) > 2 else math.atan2(g[1] - s[1], g[0] - s[0])
        out = env.solve(s[:2], g[:2], start_yaw, goal_yaw, collect_tree)
        base = dict(raw_path=out.states[:, :2].copy(), solve_time=out.solve_time, samples=out.samples,
                    vertices=out.vertices, tree=out.tree)
        if not out.exact:
            return self._failure(s, g, out.ompl_status, base)
        if env.dubins:
            dense = drop_duplicates(env.dubins_polyline(self.options.waypoint_spacing))
            pts, yaw = dense[:, :2], dense[:, 2]
        else:
            pts = shortcut(out.states, self.kmap, env.margin) if self.options.simplify else out.states
            pts = resample(pts, self.options.waypoint_spacing)
            yaw = headings(pts)
        pts = np.ascontiguousarray(pts, dtype=np.float64)
        if not polyline_valid(pts, self.kmap.net_radius, self.options.clearance - 1e-9,
                              self.kmap.squares, self.kmap.circles):
            return PlanResult(PlanStatus.NO_VALID_PATH, "post-processed path failed the clearance check", **base)
        return PlanResult(PlanStatus.SUCCESS, f"{len(pts)} waypoints, {path_length(pts):.2f} m",
                          pts, yaw, length=path_length(pts), **base)

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
