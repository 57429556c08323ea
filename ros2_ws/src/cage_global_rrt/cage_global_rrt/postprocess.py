"""Path post-processing: shortcutting, then resampling to a waypoint spacing.

Resampling only adds points on the existing straight segments, so it cannot make a valid path
invalid; shortcutting only keeps segments that pass the same exact check the planner used.
"""
from __future__ import annotations

import math

import numpy as np

from .geometry import _jit, greedy_shortcut
from .known_map import KnownMap


def shortcut(points: np.ndarray, kmap: KnownMap, margin: float) -> np.ndarray:
    """Greedy string pulling: keep the furthest visible point from each kept point."""
    pts = np.ascontiguousarray(points[:, :2], dtype=np.float64)
    if len(pts) <= 2:
        return pts
    keep = greedy_shortcut(pts, kmap.net_radius, margin, kmap.squares, kmap.circles)
    return pts[keep]


@_jit
def _resample(pts, spacing):
    n_seg = pts.shape[0] - 1
    counts = np.empty(n_seg, dtype=np.int64)
    total = 1
    for i in range(n_seg):
        d = math.hypot(pts[i + 1, 0] - pts[i, 0], pts[i + 1, 1] - pts[i, 1])
        c = int(math.ceil(d / spacing - 1e-9))
        counts[i] = c if c > 1 else 1
        total += counts[i]
    out = np.empty((total, 2))
    out[0, 0] = pts[0, 0]
    out[0, 1] = pts[0, 1]
    k = 1
    for i in range(n_seg):
        n = counts[i]
        dx = pts[i + 1, 0] - pts[i, 0]
        dy = pts[i + 1, 1] - pts[i, 1]
        for j in range(1, n + 1):
            s = j / n
            out[k, 0] = pts[i, 0] + s * dx
            out[k, 1] = pts[i, 1] + s * dy
            k += 1
    return out


def resample(points: np.ndarray, spacing: float) -> np.ndarray:
    """Insert points so no two consecutive ones are more than ``spacing`` apart (corners kept).
    ``spacing`` 0 returns the corners only. (Compiled: a request's numpy calls on a handful of
    points cost more than the shortest-path query itself.)"""
    pts = np.ascontiguousarray(np.asarray(points, dtype=np.float64)[:, :2])
    if spacing <= 0 or len(pts) < 2:
        return pts.copy()
    return _resample(pts, float(spacing))


def drop_duplicates(points: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """Remove consecutive repeats (a Dubins interpolation can repeat its end state)."""
    if len(points) < 2:
        return points
    step = np.hypot(*np.diff(points[:, :2], axis=0).T)
    return points[np.concatenate(([True], step > tol))]


@_jit
def _headings(pts):
    n = pts.shape[0]
    out = np.empty(n)
    for i in range(n - 1):
        out[i] = math.atan2(pts[i + 1, 1] - pts[i, 1], pts[i + 1, 0] - pts[i, 0])
    out[n - 1] = out[n - 2]
    return out


def headings(points: np.ndarray) -> np.ndarray:
    """Direction of travel at each waypoint: toward the next one (the last keeps the previous)."""
    pts = np.asarray(points, dtype=float)
    if len(pts) < 2:
        return np.zeros(len(pts))
    return _headings(np.ascontiguousarray(pts[:, :2]))


@_jit
def _length(pts):
    total = 0.0
    for i in range(pts.shape[0] - 1):
        total += math.hypot(pts[i + 1, 0] - pts[i, 0], pts[i + 1, 1] - pts[i, 1])
    return total


def path_length(points: np.ndarray) -> float:
    pts = np.asarray(points, dtype=float)
    if len(pts) < 2:
        return 0.0
    return float(_length(np.ascontiguousarray(pts[:, :2])))
