"""Path post-processing: shortcutting, then resampling to a waypoint spacing.

Resampling only adds points on the existing straight segments, so it cannot make a valid path
invalid; shortcutting only keeps segments that pass the same exact check the planner used.
"""
from __future__ import annotations

import math

import numpy as np

from .geometry import greedy_shortcut
from .known_map import KnownMap


def shortcut(points: np.ndarray, kmap: KnownMap, margin: float) -> np.ndarray:
    """Greedy string pulling: keep the furthest visible point from each kept point."""
    pts = np.ascontiguousarray(points[:, :2], dtype=np.float64)
    if len(pts) <= 2:
        return pts
    keep = greedy_shortcut(pts, kmap.net_radius, margin, kmap.squares, kmap.circles)
    return pts[keep]


def resample(points: np.ndarray, spacing: float) -> np.ndarray:
    """Insert points so no two consecutive ones are more than ``spacing`` apart (corners kept).
    ``spacing`` 0 returns the corners only."""
    pts = np.asarray(points, dtype=float)[:, :2]
    if spacing <= 0 or len(pts) < 2:
        return pts.copy()
    d = np.diff(pts, axis=0)
    n = np.maximum(1, np.ceil(np.hypot(d[:, 0], d[:, 1]) / spacing - 1e-9).astype(np.int64))
    seg = np.repeat(np.arange(len(d)), n)                       # segment of each new point
    j = np.arange(1, n.sum() + 1) - np.repeat(np.cumsum(n) - n, n)   # 1..n within its segment
    s = (j / n[seg])[:, None]
    return np.vstack((pts[:1], pts[seg] + s * d[seg]))


def drop_duplicates(points: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """Remove consecutive repeats (a Dubins interpolation can repeat its end state)."""
    if len(points) < 2:
        return points
    step = np.hypot(*np.diff(points[:, :2], axis=0).T)
    return points[np.concatenate(([True], step > tol))]


def headings(points: np.ndarray) -> np.ndarray:
    """Direction of travel at each waypoint: toward the next one (the last keeps the previous)."""
    pts = np.asarray(points, dtype=float)
    if len(pts) < 2:
        return np.zeros(len(pts))
    d = np.diff(pts[:, :2], axis=0)
    yaw = np.arctan2(d[:, 1], d[:, 0])
    return np.concatenate((yaw, yaw[-1:]))


def path_length(points: np.ndarray) -> float:
    pts = np.asarray(points, dtype=float)
    if len(pts) < 2:
        return 0.0
    return float(np.hypot(*np.diff(pts[:, :2], axis=0).T).sum())
