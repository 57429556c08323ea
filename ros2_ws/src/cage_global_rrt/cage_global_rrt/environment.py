"""The planning environment (OMPL Python demo style): one object owns the SimpleSetup, the state
space, the validity checker and the motion validator for one known map and one set of options.

Why an object: building the setup costs far more than a plan, so the node and the benchmark keep
one environment per map and only swap start and goal per query.
"""
from __future__ import annotations

import atexit
import gc
import math
import time
import weakref
from dataclasses import dataclass

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from .known_map import KnownMap
from .options import PlannerOptions
from .validity import SegmentMotionValidator, r2_state_checker, se2_state_checker

ou.setLogLevel(ou.LOG_WARN)

_PLANNERS = {"rrt": og.RRT, "rrtconnect": og.RRTConnect, "rrtstar": og.RRTstar,
             "informedrrtstar": og.InformedRRTstar}
_OPTIMISING = ("rrtstar", "informedrrtstar")


@dataclass
class SolveOutcome:
    """What OMPL returned for one query, in plain Python types."""

    exact: bool
    ompl_status: str
    states: np.ndarray          # (N, 2) or (N, 3) with yaw; empty when no exact solution
    solve_time: float           # seconds inside SimpleSetup.solve
    samples: int | None         # motion checks (= RRT iterations); None in Dubins mode
    vertices: int | None        # tree vertices, when collected
    tree: list[tuple[tuple[float, float], tuple[float, float]]] | None


def seed_ompl(seed: int) -> None:
    """Reseed OMPL's seed generator. OMPL logs an error when sampling already started; that is
    expected here (every plan allocates fresh samplers after this call), so it is silenced."""
    level = ou.getLogLevel()
    ou.setLogLevel(ou.LOG_NONE)
    try:
        ou.RNG.setSeed(int(seed))
    finally:
        ou.setLogLevel(level)


_LIVE: "weakref.WeakSet[CageEnvironment]" = weakref.WeakSet()


@atexit.register
def _close_all() -> None:
    """Release OMPL objects before interpreter teardown; otherwise nanobind reports the Python
    motion validators still owned by C++ as leaks at exit."""
    for env in list(_LIVE):
        env.close()
    gc.collect()


class CageEnvironment:
    """SimpleSetup over the known map: R^2 with exact straight-segment checks, or Dubins SE(2)."""

    def __init__(self, kmap: KnownMap, options: PlannerOptions) -> None:
        self.kmap = kmap
        self.options = options
        self.dubins = options.dubins
        self.margin = self.check_margin(options)
        R = kmap.net_radius
        if self.dubins:
            self.space = ob.DubinsStateSpace(options.turning_radius)
        else:
            self.space = ob.RealVectorStateSpace(2)
        bounds = ob.RealVectorBounds(2)
        bounds.setLow(-R)
        bounds.setHigh(R)
        self.space.setBounds(bounds)
        self.ss = og.SimpleSetup(self.space)
        self.si = self.ss.getSpaceInformation()
        self.motion: SegmentMotionValidator | None = None
        if self.dubins:
            self.ss.setStateValidityChecker(se2_state_checker(kmap, self.margin))
            self.si.setStateValidityCheckingResolution(options.check_resolution / self.space.getMaximumExtent())
        else:
            self.ss.setStateValidityChecker(r2_state_checker(kmap, self.margin))
            self.motion = SegmentMotionValidator(self.si, kmap, self.margin)
            self.si.setMotionValidator(self.motion)
        self.ss.setOptimizationObjective(ob.PathLengthOptimizationObjective(self.si))
        self._start = self.space.allocState()
        self._goal = self.space.allocState()
        self.planner = None
        _LIVE.add(self)

    def close(self) -> None:
        """Drop the OMPL objects (the environment cannot plan afterwards)."""
        for name in ("planner", "motion", "_start", "_goal", "si", "ss", "space"):
            self.__dict__.pop(name, None)

    @staticmethod
    def check_margin(options: PlannerOptions) -> float:
        """Margin the validity checker uses. Straight segments are checked exactly, so it is the
        clearance itself. Dubins curves are checked every ``check_resolution`` metres and then
        handed on as a polyline of chords ``waypoint_spacing`` apart, so the margin grows by half
        the check step plus the chord's sagitta: the polyline then keeps the full clearance."""
        if not options.dubins:
            return options.clearance
        spacing = options.waypoint_spacing or options.check_resolution
        sagitta = spacing * spacing / (8.0 * options.turning_radius)
        return options.clearance + 0.5 * options.check_resolution + sagitta

    def _new_planner(self):
        o = self.options
        planner = _PLANNERS[o.planner](self.si)
        planner.setRange(o.max_step)
        if hasattr(planner, "setGoalBias") and o.planner != "rrtconnect":
            planner.setGoalBias(o.goal_bias)
        return planner

    def _set(self, state, xy, yaw: float) -> None:
        if self.dubins:
            state.setXY(float(xy[0]), float(xy[1]))
            state.setYaw(float(yaw))
        else:
            state[0] = float(xy[0])
            state[1] = float(xy[1])

    def solve(self, start, goal, start_yaw: float = 0.0, goal_yaw: float = 0.0,
              collect_tree: bool = False) -> SolveOutcome:
        """One query. A fresh planner each time, so a seeded query does not depend on earlier ones
        (RRT keeps its own RNG, created with the planner)."""
        o = self.options
        if o.seed is not None:
            seed_ompl(o.seed)
        self.ss.clear()
        self.planner = self._new_planner()
        self.ss.setPlanner(self.planner)
        self._set(self._start, start, start_yaw)
        self._set(self._goal, goal, goal_yaw)
        self.ss.setStartAndGoalStates(self._start, self._goal)
        checks0 = self.motion.checks if self.motion else 0
        t0 = time.perf_counter()
        # An explicit timed condition: ``solve(seconds)`` with seconds >= 1 makes OMPL start a
        # watchdog thread per call (about 0.2 ms, more than a whole RRT plan here).
        status = self.ss.solve(ob.timedPlannerTerminationCondition(o.time_limit))
        solve_time = time.perf_counter() - t0
        exact = bool(self.ss.haveExactSolutionPath())
        samples = (self.motion.checks - checks0) if self.motion else None
        vertices, tree = self._tree(collect_tree)
        states = self._solution_states() if exact else np.zeros((0, 3 if self.dubins else 2))
        return SolveOutcome(exact, status.asString(), states, solve_time, samples, vertices, tree)

    def _solution_states(self) -> np.ndarray:
        path = self.ss.getSolutionPath()
        if self.dubins:
            return np.array([(s.getX(), s.getY(), s.getYaw()) for s in path.getStates()], dtype=float)
        return np.array([(s[0], s[1]) for s in path.getStates()], dtype=float)

    def _tree(self, collect: bool):
        if not collect or self.planner is None:
            return None, None
        pd = ob.PlannerData(self.si)
        self.planner.getPlannerData(pd)
        n = pd.numVertices()
        xy = []
        for i in range(n):
            s = pd.getVertex(i).getState()
            xy.append((s.getX(), s.getY()) if self.dubins else (s[0], s[1]))
        edges = [(xy[i], xy[j]) for i in range(n) for j in pd.getEdges(i)]
        return n, edges

    def dubins_polyline(self, spacing: float) -> np.ndarray:
        """The solution's Dubins curves as (x, y, yaw) states about ``spacing`` apart (after an
        optional OMPL simplification, which checks curves at the state resolution)."""
        if self.options.simplify:
            self.ss.simplifySolution()
        path = self.ss.getSolutionPath()
        step = spacing or self.options.check_resolution
        count = max(2, int(math.ceil(path.length() / step)) + 1)
        path.interpolate(count)
        return np.array([(s.getX(), s.getY(), s.getYaw()) for s in path.getStates()], dtype=float)
