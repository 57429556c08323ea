"""Planner options: one frozen dataclass shared by the library, the benchmark and the node.

Validation returns a message instead of raising, so a bad option reaches the caller as an
INVALID_INPUT result (the core never lets an exception escape for bad input).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

PLANNERS: tuple[str, ...] = ("rrt", "rrtconnect", "rrtstar", "informedrrtstar", "optimal")
SAMPLING_PLANNERS: tuple[str, ...] = PLANNERS[:4]   # the OMPL ones


def default_turning_radius() -> float:
    """The vehicle's turning radius (speed / yaw-rate limit = 2.86 m with the defaults)."""
    try:
        from cage_sim.vehicle import VehicleParams
        return float(VehicleParams().turning_radius)
    except (ImportError, AttributeError):  # cage_sim without the vehicle module
        return 1.0 / math.radians(20.0)


@dataclass(frozen=True)
class PlannerOptions:
    """Knobs of one plan.

    planner: rrt (the study's, default) | rrtconnect | rrtstar | informedrrtstar | optimal. The
    optimising planners (RRT*, Informed RRT*) use the whole ``time_limit`` to improve the path; the
    other OMPL ones stop at the first solution; ``optimal`` is the shortest path under the clearance
    from a visibility graph built once per map (``visibility.py``; no OMPL, no sampling, no seed).
    max_step: the planner's range (m), the study's "max step size".
    clearance: required distance (m) from the path to every known obstacle and to the net.
    time_limit: planner time budget (s).
    goal_bias: probability of sampling the goal (RRT, RRT*; > 0, as the goal is a single state).
    simplify: shortcut the raw tree path (deterministic greedy string pulling for straight
    segments, OMPL's simplifier for Dubins paths).
    waypoint_spacing: resample the result so consecutive waypoints are at most this far apart (m);
    0 keeps only the corners.
    dubins: plan over SE(2) with Dubins curves so no turn is tighter than ``turning_radius``.
    check_resolution: spacing (m) of the state checks along Dubins curves (straight segments are
    checked exactly, analytically).
    flyable: round every corner of the (R^2) path with an arc of ``turning_radius`` whose clearance
    is proven (``flyable.py``); the arcs are published as waypoints ``arc_spacing`` apart. Where the
    arcs do not fit, the path is replanned on the visibility graph with more clearance (at most
    1.25x longer); where that fails too, the corner path is returned (``PlanResult.flyable`` False)
    and its message says so.
    arc_spacing: spacing (m) of the waypoints along the arcs of a flyable path.
    seed: OMPL RNG seed (>= 1) for reproducible plans; None = not reseeded.
    """

    planner: str = "rrt"
    max_step: float = 3.0
    clearance: float = 1.0
    time_limit: float = 1.0
    goal_bias: float = 0.05
    simplify: bool = True
    waypoint_spacing: float = 1.0
    dubins: bool = False
    turning_radius: float = default_turning_radius()
    check_resolution: float = 0.1
    seed: int | None = None
    flyable: bool = False
    arc_spacing: float = 0.5

    def error(self) -> str | None:
        """Why these options are unusable, or None when they are fine."""
        if self.planner not in PLANNERS:
            return f"planner must be one of {', '.join(PLANNERS)}, got {self.planner!r}"
        positive = {"max_step": self.max_step, "time_limit": self.time_limit,
                    "turning_radius": self.turning_radius, "check_resolution": self.check_resolution,
                    "arc_spacing": self.arc_spacing}
        for name, v in positive.items():
            if not _real(v) or v <= 0:
                return f"{name} must be a positive number, got {v!r}"
        for name, v in {"clearance": self.clearance, "waypoint_spacing": self.waypoint_spacing}.items():
            if not _real(v) or v < 0:
                return f"{name} must be a number >= 0, got {v!r}"
        if not _real(self.goal_bias) or not 0.0 < self.goal_bias <= 1.0:
            # 0 would never reach the goal: it is a single state, which uniform sampling never hits
            return f"goal_bias must be in (0, 1], got {self.goal_bias!r}"
        if self.seed is not None and (isinstance(self.seed, bool) or not isinstance(self.seed, int)
                                      or not 1 <= self.seed < 2 ** 32):
            return f"seed must be an integer in [1, 2**32) or None, got {self.seed!r}"
        for name in ("simplify", "dubins", "flyable"):
            if not isinstance(getattr(self, name), bool):
                return f"{name} must be a bool, got {getattr(self, name)!r}"
        if self.dubins and self.planner == "optimal":
            return "dubins needs a sampling planner (rrt, ...); the optimal planner's turns are rounded by flyable"
        if self.dubins and self.flyable:
            return "dubins and flyable exclude each other (Dubins curves are flyable already)"
        return None

    def with_(self, **changes: Any) -> "PlannerOptions":
        return replace(self, **changes)

    @classmethod
    def from_mapping(cls, values: dict[str, Any]) -> "PlannerOptions":
        """Build from a mapping (YAML / ROS parameters); unknown keys raise ValueError naming them."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(values) - known)
        if unknown:
            raise ValueError(f"unknown planner option(s): {', '.join(unknown)} (known: {', '.join(sorted(known))})")
        return cls(**values)


def _real(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


# The node's parameters: name -> default (the default's type is the parameter's type). planner_seed 0
# means "not reseeded" (ROS parameters have no None); the default 1 makes plans reproducible, so the
# graph plans what offline evaluation plans. (Not "seed": that name is the scenario's, shared by the
# whole graph.) frame_id is the node's, not the planner's.
NODE_PARAMETERS: dict[str, Any] = {
    "planner": "rrt", "max_step": 3.0, "clearance": 1.0, "time_limit": 1.0, "goal_bias": 0.05,
    "simplify": True, "waypoint_spacing": 0.0, "dubins": False,   # corners: what the graph flies (rrt.yaml)
    "turning_radius": default_turning_radius(), "check_resolution": 0.1, "planner_seed": 1,
    "flyable": False, "arc_spacing": 0.5, "frame_id": "map",
    "obstacle_layer": False, "layer_confirm_scans": 3, "layer_forget_scans": 3,
    "net_model": "nominal", "current": [0.0, 0.0],   # known_map.NET_MODELS; the site's mean current, m/s
}
# Node parameters that are not planner options: the node's own and the obstacle layer's.
NODE_ONLY = ("frame_id", "planner_seed", "obstacle_layer", "layer_confirm_scans", "layer_forget_scans",
             "net_model", "current")
# Node parameters that ``ros2 param set`` changes at run time (the planner map is rebuilt); the
# others are read at start only.
RUNTIME = ("net_model", "current")


class InvalidParameters(ValueError):
    """A node parameter the planner cannot use (raised while the node starts)."""


def options_from_parameters(values: dict[str, Any]) -> PlannerOptions:
    """PlannerOptions from node parameter values; InvalidParameters names the problem."""
    vals = {k: v for k, v in values.items() if k not in NODE_ONLY}
    try:
        vals["seed"] = int(values.get("planner_seed", 0)) or None
        opts = PlannerOptions.from_mapping(vals)
    except (TypeError, ValueError) as err:
        raise InvalidParameters(str(err)) from None
    err = opts.error()
    if err:
        raise InvalidParameters(f"parameter {err}")
    return opts
