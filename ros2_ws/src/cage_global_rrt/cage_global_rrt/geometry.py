"""Scalar collision kernels for the known map, compiled with numba when it is installed.

Why this shape: OMPL calls back into Python once per motion check, and that callback dominates a
plan. Each kernel takes plain floats and two small packed arrays, so a compiled call costs about
0.2 us and the same code runs (slower) as pure Python where numba is missing.

Geometry: the known map is the net (a circle of radius R about the origin), axis-aligned squares
(rows cx, cy, half_side) and circles (rows cx, cy, radius). A point or a straight segment is valid
when its exact clearance (the distance ``World.clearance`` measures) is at least ``margin``: the
obstacles are inflated with rounded corners, the net shrunk by ``margin``. Segments are tested
analytically, so no segment can cut a corner between two checked points.
"""
from __future__ import annotations

import math

import numpy as np

try:
    from numba import njit as _njit
    HAVE_NUMBA = True
except ImportError:  # pragma: no cover - exercised only where numba is not installed
    HAVE_NUMBA = False


def _jit(fn):
    return _njit(cache=True, nogil=True)(fn) if HAVE_NUMBA else fn


@_jit
def point_box_distance(px, py, cx, cy, h):
    """Distance from a point to an axis-aligned square (0 inside)."""
    dx = abs(px - cx) - h
    dy = abs(py - cy) - h
    if dx < 0.0:
        dx = 0.0
    if dy < 0.0:
        dy = 0.0
    return math.sqrt(dx * dx + dy * dy)


@_jit
def point_segment_distance(px, py, ax, ay, bx, by):
    """Distance from a point to the segment a-b."""
    ux = bx - ax
    uy = by - ay
    L2 = ux * ux + uy * uy
    t = 0.0
    if L2 > 0.0:
        t = ((px - ax) * ux + (py - ay) * uy) / L2
        if t < 0.0:
            t = 0.0
        elif t > 1.0:
            t = 1.0
    dx = ax + t * ux - px
    dy = ay + t * uy - py
    return math.sqrt(dx * dx + dy * dy)


@_jit
def segment_hits_box(ax, ay, bx, by, cx, cy, h):
    """Whether segment a-b touches the closed square (slab test)."""
    t0 = 0.0
    t1 = 1.0
    for k in range(2):
        if k == 0:
            p, d, lo, hi = ax, bx - ax, cx - h, cx + h
        else:
            p, d, lo, hi = ay, by - ay, cy - h, cy + h
        if d == 0.0:
            if p < lo or p > hi:
                return False
        else:
            ta = (lo - p) / d
            tb = (hi - p) / d
            if ta > tb:
                ta, tb = tb, ta
            if ta > t0:
                t0 = ta
            if tb < t1:
                t1 = tb
            if t0 > t1:
                return False
    return True


@_jit
def segment_box_distance(ax, ay, bx, by, cx, cy, h):
    """Distance from segment a-b to a square: 0 when they touch, else the least of the endpoint
    distances to the square and the corner distances to the segment (both are convex)."""
    if segment_hits_box(ax, ay, bx, by, cx, cy, h):
        return 0.0
    d = min(point_box_distance(ax, ay, cx, cy, h), point_box_distance(bx, by, cx, cy, h))
    for sx in (-1.0, 1.0):
        for sy in (-1.0, 1.0):
            e = point_segment_distance(cx + sx * h, cy + sy * h, ax, ay, bx, by)
            if e < d:
                d = e
    return d


@_jit
def point_valid(x, y, net_radius, margin, squares, circles):
    """Clearance of (x, y) to the net and every obstacle is at least ``margin``."""
    if not (x == x and y == y):  # NaN
        return False
    r = net_radius - margin
    if r <= 0.0 or x * x + y * y > r * r:
        return False
    for i in range(squares.shape[0]):
        cx = squares[i, 0]
        cy = squares[i, 1]
        h = squares[i, 2]
        dx = abs(x - cx) - h
        dy = abs(y - cy) - h
        if dx < margin and dy < margin:
            if dx <= 0.0 or dy <= 0.0 or dx * dx + dy * dy < margin * margin:
                return False
    for i in range(circles.shape[0]):
        dx = x - circles[i, 0]
        dy = y - circles[i, 1]
        rr = circles[i, 2] + margin
        if dx * dx + dy * dy < rr * rr:
            return False
    return True


@_jit
def segment_valid(ax, ay, bx, by, net_radius, margin, squares, circles):
    """Every point of segment a-b has clearance >= ``margin`` (exact, no sampling)."""
    if not (ax == ax and ay == ay and bx == bx and by == by):
        return False
    r = net_radius - margin
    if r <= 0.0 or ax * ax + ay * ay > r * r or bx * bx + by * by > r * r:
        return False  # the shrunk net disc is convex: both ends inside = whole segment inside
    lox = min(ax, bx) - margin
    hix = max(ax, bx) + margin
    loy = min(ay, by) - margin
    hiy = max(ay, by) + margin
    for i in range(squares.shape[0]):
        cx = squares[i, 0]
        cy = squares[i, 1]
        h = squares[i, 2]
        if cx + h < lox or cx - h > hix or cy + h < loy or cy - h > hiy:
            continue  # bounding boxes apart: cannot come within margin
        if segment_box_distance(ax, ay, bx, by, cx, cy, h) < margin:
            return False
    for i in range(circles.shape[0]):
        cx = circles[i, 0]
        cy = circles[i, 1]
        rr = circles[i, 2] + margin
        if point_segment_distance(cx, cy, ax, ay, bx, by) < rr:
            return False
    return True


@_jit
def polyline_valid(pts, net_radius, margin, squares, circles):
    """Every segment of an (N, 2) polyline is valid."""
    for i in range(pts.shape[0] - 1):
        if not segment_valid(pts[i, 0], pts[i, 1], pts[i + 1, 0], pts[i + 1, 1],
                             net_radius, margin, squares, circles):
            return False
    if pts.shape[0] == 1:
        return point_valid(pts[0, 0], pts[0, 1], net_radius, margin, squares, circles)
    return True


@_jit
def greedy_shortcut(pts, net_radius, margin, squares, circles):
    """Indices of a string-pulled path: from each kept point jump to the furthest point that is
    visible in a straight valid segment. Deterministic (unlike random shortcutting), so seeded
    plans stay reproducible."""
    n = pts.shape[0]
    keep = np.empty(n, dtype=np.int64)
    k = 0
    i = 0
    keep[k] = 0
    k += 1
    while i < n - 1:
        j = n - 1
        while j > i + 1 and not segment_valid(pts[i, 0], pts[i, 1], pts[j, 0], pts[j, 1],
                                              net_radius, margin, squares, circles):
            j -= 1
        keep[k] = j
        k += 1
        i = j
    return keep[:k]


def empty_rows() -> np.ndarray:
    return np.zeros((0, 3), dtype=np.float64)
