"""Picking a mission up again after a node restart (pure; no ROS import).

A restarted node learns the plan from a latched topic, but the plan starts where the mission started.
Following it from its first waypoint would send the vehicle back to the mission start (and make the
judge call the detour a "wander"), so a node that joins a mission under way starts from the plan's
segment nearest the vehicle instead: the waypoints already behind it are dropped.
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
    return pts[int(np.argmin(d)) + 1:].copy()

