"""A navigation mission's bookkeeping, as the navigator node reports it (pure; no ROS import).

The navigator owns mission state the way Nav2's bt_navigator does: it checks a goal, asks the planner
for a route, hands the route to the graph under a mission id, and turns what happens into action
feedback and a result. What it counts lives here, so it can be tested without processes: distance to
go along the route (the same ``RouteTracker`` the judge and the policy use), distinct decisions,
decisions the safety shield replaced, distance travelled and simulation time since the start.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from .route import KnownOutline, RouteTracker

# Navigate.action result codes (kept equal to the .action file's constants; tested).
GOAL_REACHED, COLLISION, WANDER, TIMEOUT, PLANNER_FAILED, PREEMPTED, CANCELED, NAVIGATOR_STOPPED = range(8)
OUTCOME_CODES = {"goal": GOAL_REACHED, "collision": COLLISION, "wander": WANDER, "timeout": TIMEOUT}
CODE_NAMES = {GOAL_REACHED: "goal", COLLISION: "collision", WANDER: "wander", TIMEOUT: "timeout",
              PLANNER_FAILED: "planner_failed", PREEMPTED: "preempted", CANCELED: "canceled",
              NAVIGATOR_STOPPED: "navigator_stopped"}


@dataclass
class MissionProgress:
    """What one mission has done so far; updated from odometry and setpoints."""

    mission_id: int
    goal: tuple[float, float]
    route: np.ndarray | None = None
    tracker: RouteTracker | None = None
    start_ns: int | None = None          # sim time of the first decision (STARTED)
    now_ns: int = 0
    pose: tuple[float, float, float] | None = None
    travelled: float = 0.0
    decisions: set[int] = field(default_factory=set)
    shielded: set[int] = field(default_factory=set)
    waypoint_radius: float = 2.0
    known: KnownOutline | None = None    # the known map: the route's goal in sight, as the judge's tracker

    def set_route(self, route: np.ndarray, pose: tuple[float, float, float] | None) -> None:
        """A (new) route; the tracker starts at the current pose, or the route's first point."""
        self.route = np.asarray(route, dtype=float).reshape(-1, 2)
        start = pose[:2] if pose is not None else self.route[0]
        self.tracker = RouteTracker(start, self.route, self.waypoint_radius, self.known)

    def set_known(self, known: KnownOutline | None) -> None:
        """The known map arrived (or changed): the tracker flies to a goal in sight across it, so the
        distance left is the one the judge and ``policy_node`` measure (``route.RouteTracker``)."""
        self.known = known
        if self.tracker is not None:
            self.tracker.known = known

    @property
    def path_length(self) -> float:
        return self.tracker.length if self.tracker is not None else 0.0

    def start(self, t_ns: int, pose: Sequence[float]) -> None:
        """The simulator started judging: the route starts at this pose and time."""
        self.start_ns, self.now_ns = t_ns, t_ns
        self.pose = (float(pose[0]), float(pose[1]), float(pose[2]) if len(pose) > 2 else 0.0)
        if self.route is not None:
            self.set_route(self.route, self.pose)

    def on_pose(self, t_ns: int, pose: tuple[float, float, float]) -> None:
        if self.pose is not None and self.start_ns is not None and t_ns >= self.start_ns:
            self.travelled += math.hypot(pose[0] - self.pose[0], pose[1] - self.pose[1])
        self.pose, self.now_ns = pose, max(self.now_ns, t_ns)
        if self.tracker is not None:
            self.tracker.advance(pose[0], pose[1])

    def on_setpoint(self, decision: int, shielded: bool) -> None:
        self.decisions.add(decision)
        if shielded:
            self.shielded.add(decision)

    def distance_remaining(self) -> float:
        if self.tracker is None or self.pose is None:
            return math.hypot(self.goal[0] - (self.pose or (0, 0))[0], self.goal[1] - (self.pose or (0, 0))[1])
        return self.tracker.remaining(self.pose[0], self.pose[1])

    @property
    def elapsed_ns(self) -> int:
        return 0 if self.start_ns is None else max(0, self.now_ns - self.start_ns)


def goal_problem(goal: Sequence[float], net_radius: float, margin: float, squares, circles,
                 point_valid) -> tuple[str, str] | None:
    """Why a goal cannot be flown to, with the planner's own validity test ``point_valid`` (the one
    its start/goal checks use): ("GOAL_OUTSIDE_NET" | "GOAL_OCCUPIED" | "INVALID_INPUT", reason), or None."""
    x, y = float(goal[0]), float(goal[1])
    if not (math.isfinite(x) and math.isfinite(y)):
        return "INVALID_INPUT", f"goal ({x}, {y}) is not finite"
    r = math.hypot(x, y)
    if r > net_radius:
        return "GOAL_OUTSIDE_NET", (f"goal ({x:.2f}, {y:.2f}) is {r - net_radius:.2f} m outside the net "
                                    f"(radius {net_radius:g} m)")
    if not point_valid(x, y, net_radius, margin, squares, circles):
        return "GOAL_OCCUPIED", (f"goal ({x:.2f}, {y:.2f}) is closer than the planner's clearance "
                                 f"{margin:.2f} m to a known obstacle or the net")
    return None
