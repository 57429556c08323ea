"""Route progress: which waypoint is current, how far along the route the vehicle is.

One definition used by the mission judge (env, evaluator, simulator node) and by the policy node, so
the waypoint the policy steers to in the node graph is the one it steered to in offline evaluation.
An intermediate waypoint counts as reached within ``waypoint_radius`` or once the vehicle has passed
it (its projection on the segment goes beyond the end); the last one is the goal. A vehicle within
``waypoint_radius`` of a later waypoint (the goal included) goes on from there: the earlier ones it
went round are not flown back to. With the known map (``known``, session 46) a vehicle that is nearer
the goal than its waypoint, within ``GOAL_IN_SIGHT`` m of it, with the straight way there
``SIGHT_CLEARANCE`` m clear of the map, flies straight to the goal (``RouteTracker.advance``).
"""
from __future__ import annotations

import math
from typing import Protocol, Sequence

import numpy as np

from .vehicle import wrap_angle

# m: a goal this near, and nearer than the waypoint, with the way clear: fly to it. 8, 12 and 16 m
# gave the same counts within 4 goals of 2000-3000 on a tuning seed (docs/results/tune_goal_in_sight_s47.md).
GOAL_IN_SIGHT = 8.0
SIGHT_CLEARANCE = 1.0    # m the straight way to it keeps from the known map (the shield's min_clearance)


class KnownOutline(Protocol):
    """What the tracker asks of the known map (``map_points.MapPoints``)."""

    def segment_clearance(self, a, b) -> float: ...


class RouteTracker:
    """The current waypoint of a route flown from ``start_xy``. ``known``: the known map (the
    planner's: known obstacles and the nominal net), for the goal in sight (``advance``); None: the
    route's order alone. It may be set later (``policy_node`` gets the map on a topic)."""

    def __init__(self, start_xy: Sequence[float], route: Sequence[Sequence[float]], waypoint_radius: float = 2.0,
                 known: KnownOutline | None = None):
        self.route = np.asarray(route, dtype=float).reshape(-1, 2)
        if len(self.route) == 0:
            raise ValueError("a route needs at least one waypoint (the goal)")
        self.waypoint_radius = waypoint_radius
        self.known = known
        self.sighted = False     # whether the goal in sight took the vehicle off the route's order
        self.index = 0
        self.prev = np.asarray(start_xy[:2], dtype=float).copy()
        pts = np.vstack([self.prev, self.route])
        self.seg_lengths = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        self.length = float(self.seg_lengths.sum())

    @property
    def goal(self) -> np.ndarray:
        return self.route[-1]

    @property
    def at_last(self) -> bool:
        return self.index == len(self.route) - 1

    def advance(self, x: float, y: float) -> bool:
        """Move past every waypoint reached or passed from (x, y); True if the index changed.

        Why the jump to a later waypoint within reach: the reactive layer leaves the route round
        what the map does not show, and sometimes comes to a later waypoint, or to the goal itself,
        before an earlier one. Following the route in order would then turn it back, away from the
        goal, for a waypoint that no longer matters (sea matrix, 0.5 m/s near the net: missions
        that came within 1 m of the goal, flew away and timed out).

        Why the goal in sight (with ``known``): a route's corner takes the vehicle round what the map
        shows; once the current, or something the map does not show, has put the vehicle nearer the
        goal than the corner, with nothing of the map on the straight way (``SIGHT_CLEARANCE``), the
        corner no longer matters, and turning back to it cost missions: 5 of the 11 timeouts of the
        shielded default in sea cell 23 (0.5 m/s, goal by the net) came within 4.5-7.9 m of the goal
        while the tracker held an intermediate waypoint, and timed out. The route then runs straight
        from the vehicle to the goal (the wander test measures from that segment). Over the 24 sea
        cells the shielded default went 23,937 -> 23,956 goals of 24,000, no cell worse, every cell
        at >= 99 % (docs/notes/sessions.md, session 46)."""
        start = self.index
        ahead = self._within_reach_ahead(x, y)
        if ahead > self.index:
            self.prev = self.route[ahead - 1].copy()
            self.index = ahead
        while not self.at_last:
            b = self.route[self.index]
            if math.hypot(b[0] - x, b[1] - y) < self.waypoint_radius or self._fraction(x, y) >= 1.0:
                self.prev = b.copy()
                self.index += 1
            else:
                break
        if self._goal_in_sight(x, y):
            self.prev = np.array([x, y], dtype=float)
            self.index = len(self.route) - 1
            self.sighted = True
        return self.index != start

    def _goal_in_sight(self, x: float, y: float) -> bool:
        """Not at the goal yet, the goal within ``GOAL_IN_SIGHT`` m and nearer than the waypoint,
        and the straight way to it ``SIGHT_CLEARANCE`` m clear of the known map."""
        if self.known is None or self.at_last:
            return False
        g, w = self.route[-1], self.route[self.index]
        to_goal = math.hypot(g[0] - x, g[1] - y)
        return to_goal <= GOAL_IN_SIGHT and to_goal < math.hypot(w[0] - x, w[1] - y) \
            and self.known.segment_clearance((x, y), g) >= SIGHT_CLEARANCE

    def _within_reach_ahead(self, x: float, y: float) -> int:
        """The last waypoint after the current one within ``waypoint_radius`` of (x, y), else the
        current index."""
        later = self.route[self.index + 1:]
        near = np.flatnonzero(np.hypot(later[:, 0] - x, later[:, 1] - y) < self.waypoint_radius)
        return self.index + 1 + int(near[-1]) if len(near) else self.index

    def _fraction(self, x: float, y: float) -> float:
        """How far along the current segment (x, y) projects: 0 at its start, 1 at its end. A
        zero-length segment (a waypoint on top of the previous one) counts as passed."""
        a, b = self.prev, self.route[self.index]
        ab = b - a
        n2 = float(ab @ ab)
        return math.inf if n2 == 0 else float((x - a[0]) * ab[0] + (y - a[1]) * ab[1]) / n2

    def waypoint(self, x: float, y: float, yaw: float) -> tuple[float, float]:
        """Distance (m) and body-frame heading error (rad, left positive) to the current waypoint."""
        wx, wy = self.route[self.index]
        dx, dy = wx - x, wy - y
        return math.hypot(dx, dy), wrap_angle(math.atan2(dy, dx) - yaw)

    def remaining(self, x: float, y: float) -> float:
        wx, wy = self.route[self.index]
        return math.hypot(wx - x, wy - y) + float(self.seg_lengths[self.index + 1:].sum())

    def segment_offset(self, x: float, y: float) -> float:
        """Distance from (x, y) to the current segment (previous waypoint -> current waypoint)."""
        a, b = self.prev, self.route[self.index]
        s = min(1.0, max(0.0, self._fraction(x, y)))
        return math.hypot(x - a[0] - s * (b[0] - a[0]), y - a[1] - s * (b[1] - a[1]))


# policy_node's replan parameters (replan_after, min_progress, replan_offset), also used by the offline
# evaluator's ``--replan on`` so both ask for a new plan at the same decisions.
REPLAN_DEFAULTS = {"replan_after": 40, "min_progress": 2.0, "replan_offset": 8.0}


class Progress:
    """Decisions since the route left last shrank by ``min_progress`` m: the count both watches
    below act on (one definition of "no progress" for the replan and the stall hand-over)."""

    def __init__(self, min_progress: float):
        self.min_progress = float(min_progress)
        self.restart()

    def restart(self, best: float = math.inf) -> None:
        """Count from here: ``best`` the route left now (inf: the next decision is progress)."""
        self.best, self.since = best, 0

    def step(self, remaining: float) -> int:
        """One decision with ``remaining`` m left: decisions since the last progress."""
        if remaining < self.best - self.min_progress:
            self.best, self.since = remaining, 0
        else:
            self.since += 1
        return self.since


class ReplanWatch:
    """When a vehicle following a route should ask the global planner for a new one.

    Two reasons: no progress along the route for ``after`` decisions (stuck behind an unknown
    obstacle, or orbiting), and, when ``max_offset`` > 0, farther than ``max_offset`` from the
    current segment. Why the second: the reactive layer may leave a route that goes the long way
    round (e.g. a planner that routed around returns seen from the start, through a gap the
    reactive layer will not take) and head for the goal across open water; the judge calls that a
    "wander" at ``wander_distance`` (15 m), so a new plan from where the vehicle is is asked for
    well before. After a request the off-route reason rests for ``after`` decisions (a planner that
    keeps failing is not asked at every decision); ``reset`` (a new route) clears both.
    """

    def __init__(self, after: int, min_progress: float, max_offset: float = 0.0):
        self.after, self.min_progress, self.max_offset = int(after), float(min_progress), float(max_offset)
        self.reset()

    @classmethod
    def defaults(cls) -> "ReplanWatch":
        """A watch with policy_node's default parameters (``REPLAN_DEFAULTS``)."""
        d = REPLAN_DEFAULTS
        return cls(d["replan_after"], d["min_progress"], d["replan_offset"])

    def reset(self) -> None:
        self.progress, self.since_request = Progress(self.min_progress), math.inf

    def update(self, tracker: RouteTracker, x: float, y: float) -> str | None:
        """One decision at (x, y): the reason to replan now, or None."""
        self.since_request += 1
        remaining = tracker.remaining(x, y)
        if self.progress.step(remaining) >= self.after:
            return self._request(remaining, f"no progress along the route for {self.after} decisions")
        offset = tracker.segment_offset(x, y)
        if 0 < self.max_offset < offset and self.since_request >= self.after:
            return self._request(remaining, f"{offset:.1f} m off the route")
        return None

    def _request(self, remaining: float, reason: str) -> str:
        self.progress.restart(remaining)
        self.since_request = 0
        return reason


class StallWatch:
    """When a shielded policy that makes no progress along its route is handed to the classical
    controller, and when it gets the vehicle back.

    Why: the learned policies sometimes loop among obstacles near a waypoint, safely but for ever
    (most of the shielded driver's timeouts in the sea matrix: 0.9 % of missions at 0.5 m/s). A new
    plan (``ReplanWatch``, after 40 decisions) puts the same policy in the same place, and it loops
    again. So after ``after`` decisions without ``min_progress`` m of progress along the route the
    controller flies (still checked by the shield, like any action) until the vehicle is ``gain`` m
    further along than it ever was, or for ``hold`` decisions; then the policy has it again. Near
    the goal (``gain`` or less from it) that means the controller flies to the goal.

    A route that grows by more than ``jump`` m between two decisions is a new route (a replan; no
    decision flies that far, even drifting at 0.5 m/s): progress counts from there, and a
    controller that is flying goes on flying the new route (the policy had stalled on the old one).
    """

    def __init__(self, after: int = 15, min_progress: float = 1.0, hold: int = 30, gain: float = 5.0,
                 jump: float = 2.0):
        if after < 1 or hold < 1 or min_progress <= 0 or gain <= 0 or jump <= 0:
            raise ValueError(f"stall watch: need after ({after}) >= 1, hold ({hold}) >= 1 and "
                             f"min_progress ({min_progress}), gain ({gain}), jump ({jump}) > 0")
        self.after, self.min_progress, self.hold, self.gain, self.jump = int(after), float(min_progress), \
            int(hold), float(gain), float(jump)
        self.reset()

    def reset(self) -> None:
        self.progress, self.left, self.target, self.last = Progress(self.min_progress), 0, -math.inf, math.inf

    def update(self, remaining: float) -> bool:
        """One decision with ``remaining`` m of route left: True = the controller flies it."""
        if not math.isfinite(remaining):
            return False
        if remaining > self.last + self.jump:      # a new route: progress counts from here
            self.progress.restart()
            self.target = remaining - self.gain    # a controller flying goes on, on the new route
        self.last = remaining
        if self.left > 0:
            self.left -= 1
            if remaining >= self.target and self.left > 0:
                return True
            self.left = 0                          # the policy has the vehicle again
            self.progress.restart(remaining)
            return False
        if self.progress.step(remaining) >= self.after:
            self.left, self.target = self.hold, min(self.progress.best, remaining) - self.gain
            self.progress.restart(self.progress.best)    # the count starts again after the hand-back
            return True
        return False
