"""Route progress: which waypoint is current, how far along the route the vehicle is.

One definition used by the mission judge (env, evaluator, simulator node) and by the policy node, so
the waypoint the policy steers to in the node graph is the one it steered to in offline evaluation.
An intermediate waypoint counts as reached within ``waypoint_radius`` or once the vehicle has passed
it (its projection on the segment goes beyond the end); the last one is the goal.
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from .vehicle import wrap_angle


class RouteTracker:
    def __init__(self, start_xy: Sequence[float], route: Sequence[Sequence[float]], waypoint_radius: float = 2.0):
        self.route = np.asarray(route, dtype=float).reshape(-1, 2)
        if len(self.route) == 0:
            raise ValueError("a route needs at least one waypoint (the goal)")
        self.waypoint_radius = waypoint_radius
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
        """Move past every waypoint reached or passed from (x, y); True if the index changed."""
        start = self.index
        while not self.at_last:
            b = self.route[self.index]
            if math.hypot(b[0] - x, b[1] - y) < self.waypoint_radius or self._fraction(x, y) >= 1.0:
                self.prev = b.copy()
                self.index += 1
            else:
                break
        return self.index != start

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
