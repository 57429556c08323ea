"""Picking a mission up again after a node restart (pure; no ROS import).

A restarted node learns the plan from a latched topic, but the plan starts where the mission started.
Following it from its first waypoint would send the vehicle back to the mission start (and make the
judge call the detour a "wander"), so a node that joins a mission under way starts from the plan's
segment nearest the vehicle instead: the waypoints already behind it are dropped. The simulator and
the policy apply the same rule at the same decision, so the judge and the policy agree on the route.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np


def remaining_route(points: Sequence[Sequence[float]] | np.ndarray, xy: Sequence[float]) -> np.ndarray:
    """The waypoints of ``points`` still ahead of a vehicle at ``xy``: those after the start of the
    segment nearest to it (the last waypoint, the goal, is always kept)."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(pts) < 2:
        return pts.copy()
    p = np.asarray(xy[:2], dtype=float)
    a, b = pts[:-1], pts[1:]
    ab = b - a
    n2 = np.einsum("ij,ij->i", ab, ab)
    s = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.where(n2 > 0, n2, 1.0), 0.0, 1.0)
    d = np.linalg.norm(a + s[:, None] * ab - p, axis=1)
    i = int(np.argmin(d))
    if i == 0 and s[0] == 0.0:
        return pts.copy()   # still before the first waypoint: nothing is behind
    return pts[i + 1:].copy()


def joining_under_way(first_mission_seen: bool, t_ns: int) -> bool:
    """A node that starts following a mission as the first one it has seen, at a decision after the
    clock's start, was (re)started while that mission ran: it must not fly the route from its start."""
    return first_mission_seen and t_ns > 0

