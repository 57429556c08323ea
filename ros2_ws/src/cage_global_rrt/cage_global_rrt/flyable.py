"""Flyable paths: every corner of a polyline replaced by an arc of the vehicle's turning radius.

Why fillets and not Dubins: the planner's polylines are already shortest (or near it); rounding
each corner with a circle tangent to both legs gives a curvature-bounded path of nearly the same
length in microseconds, where OMPL's Dubins planning takes milliseconds to hundreds of ms.

How: at a corner turning by theta, the arc of radius rho starts rho * tan(theta / 2) before the
corner. Where two neighbouring arcs would overlap on a short leg (a polyline wrapping a rounded
obstacle turns in many small steps), the two corners are merged into one at the intersection of
the outer legs, which is then rounded once. The arc is published as chords ``spacing`` apart whose
points lie on the arc; a chord is at most its sagitta s^2 / (8 rho) from the arc, so every chord is
tested with the exact segment kernel at ``clearance + sagitta``: then the arc itself and the chords
both keep the clearance (a proof, not a sampling hope). Straight parts are tested exactly at the
clearance. A fillet that fails is reported (None); the planner then replans with more clearance.
"""
from __future__ import annotations

import math

import numpy as np

from .geometry import segment_valid
from .known_map import KnownMap


Point = tuple[float, float]


def _turn(a: Point, b: Point, c: Point) -> tuple[float, float]:
    """(turn angle in [0, pi], signed cross product) of the corner a-b-c."""
    ux, uy = b[0] - a[0], b[1] - a[1]
    wx, wy = c[0] - b[0], c[1] - b[1]
    cross = ux * wy - uy * wx
    return abs(math.atan2(cross, ux * wx + uy * wy)), cross


def _tangent_length(a: Point, b: Point, c: Point, radius: float) -> float:
    return radius * math.tan(0.5 * _turn(a, b, c)[0])


def merge_corners(points, radius: float, max_turn: float = math.radians(170.0)) -> np.ndarray | None:
    """Corners so that every fillet of ``radius`` fits on its legs, or None where that needs merging
    an S-bend or a turn sharper than ``max_turn`` (no corner point exists)."""
    pts: list[Point] = [(float(p[0]), float(p[1])) for p in _dedup(points)]
    t = [0.0] + [_tangent_length(pts[i - 1], pts[i], pts[i + 1], radius) for i in range(1, len(pts) - 1)] + [0.0]
    i = 0
    while i < len(pts) - 1:
        if t[i] + t[i + 1] <= math.dist(pts[i], pts[i + 1]) + 1e-12:
            i += 1
            continue
        if i == 0 or i + 1 == len(pts) - 1:
            return None  # the first or last leg is too short for its fillet
        # merge corners i and i+1 into the intersection of legs (i-1, i) and (i+1, i+2)
        a, b, c, d = pts[i - 1], pts[i], pts[i + 1], pts[i + 2]
        (_, c1), (_, c2) = _turn(a, b, c), _turn(b, c, d)
        ux, uy = b[0] - a[0], b[1] - a[1]
        wx, wy = d[0] - c[0], d[1] - c[1]
        lu, lw = math.hypot(ux, uy), math.hypot(wx, wy)
        ux, uy, wx, wy = ux / lu, uy / lu, wx / lw, wy / lw
        den = ux * wy - uy * wx
        if c1 * c2 < 0 or abs(den) < 1e-12 or abs(math.atan2(den, ux * wx + uy * wy)) > max_turn:
            return None
        s = ((c[0] - a[0]) * wy - (c[1] - a[1]) * wx) / den
        if s <= 0:
            return None
        pts[i:i + 2] = [(a[0] + s * ux, a[1] + s * uy)]
        t[i:i + 2] = [_tangent_length(pts[i - 1], pts[i], pts[i + 1], radius)]
        i = max(0, i - 2)   # the merged corner's longer tangent may now overlap the previous one
    return np.asarray(pts)


def _dedup(points, tol: float = 1e-9) -> np.ndarray:
    """Drop repeated points and interior points with no turn."""
    pts = np.asarray(points, dtype=float)[:, :2]
    out: list[Point] = [(float(pts[0, 0]), float(pts[0, 1]))]
    for x, y in pts[1:].tolist():
        if math.dist((x, y), out[-1]) > tol:
            out.append((x, y))
    if len(out) > 2:
        k = [out[0]]
        for i in range(1, len(out) - 1):
            angle, _ = _turn(k[-1], out[i], out[i + 1])
            if angle > 1e-12:
                k.append(out[i])
        k.append(out[-1])
        out = k
    return np.asarray(out)


Arc = tuple[float, float, float]   # centre x, centre y, radius


def fillet(points: np.ndarray, kmap: KnownMap, clearance: float, radius: float, spacing: float = 0.5,
           keep_sharp: bool = False, merge: bool = True) -> tuple[np.ndarray, list[Arc], int] | None:
    """(waypoints, arcs, sharp): the polyline with its corners rounded, arcs as chords ``spacing``
    apart, each arc as (centre x, centre y, radius), and how many corners stayed sharp. Without
    ``keep_sharp`` a corner whose arc does not fit or breaks the clearance makes the whole result
    None; with it, that corner stays a corner (when its straight legs keep the clearance) and the
    others are rounded. ``merge`` False rounds the corners as they are (no merged corner points,
    whose extended legs may cross an obstacle): neighbours whose arcs would overlap stay sharp.
    Straight legs are returned as their two ends (the caller resamples them)."""
    corners = merge_corners(points, radius) if merge else _dedup(points)
    if corners is None:
        return None
    R, sq, ci = kmap.net_radius, kmap.squares, kmap.circles
    c = corners.tolist()
    out: list[list[float]] = [c[0]]
    arcs: list[tuple[float, float, float]] = []
    sharp = 0
    for i in range(1, len(c) - 1):
        a, b, d = c[i - 1], c[i], c[i + 1]
        arc = _arc(out[-1], a, b, d, radius, spacing, clearance, R, sq, ci)
        if arc is None:
            if not keep_sharp or not segment_valid(out[-1][0], out[-1][1], b[0], b[1], R, clearance, sq, ci):
                return None
            out.append(b)
            sharp += 1
            continue
        chord, centre = arc
        out.extend(chord)
        arcs.append(centre)
    end = c[-1]
    if not segment_valid(out[-1][0], out[-1][1], end[0], end[1], R, clearance, sq, ci):
        return None
    out.append(end)
    return _dedup_keep(np.asarray(out)), arcs, sharp


def _arc(prev, a, b, d, radius, spacing, clearance, R, sq, ci):
    """(chord points, (cx, cy, radius)) of the fillet at corner b coming from ``prev``, or None
    when the straight run to it or the arc breaks the clearance."""
    theta, cross = _turn(a, b, d)
    lu, lw = math.dist(a, b), math.dist(b, d)
    ux, uy = (b[0] - a[0]) / lu, (b[1] - a[1]) / lu
    wx, wy = (d[0] - b[0]) / lw, (d[1] - b[1]) / lw
    t = radius * math.tan(0.5 * theta)
    if t > math.dist(prev, b) + 1e-12 or t > lw + 1e-12:
        return None   # the arc needs more of a leg than is left
    p = [b[0] - t * ux, b[1] - t * uy]
    q = [b[0] + t * wx, b[1] + t * wy]
    side = 1.0 if cross > 0 else -1.0          # left turn: centre on the left
    cx, cy = p[0] - side * radius * uy, p[1] + side * radius * ux
    a0 = math.atan2(p[1] - cy, p[0] - cx)
    n = max(1, int(math.ceil(radius * theta / spacing)))
    sag = (radius * theta / n) ** 2 / (8.0 * radius)
    chord = [p] + [[cx + radius * math.cos(a0 + side * theta * k / n),
                    cy + radius * math.sin(a0 + side * theta * k / n)] for k in range(1, n)] + [q]
    if not segment_valid(prev[0], prev[1], p[0], p[1], R, clearance, sq, ci):
        return None
    for s0, s1 in zip(chord[:-1], chord[1:]):
        if not segment_valid(s0[0], s0[1], s1[0], s1[1], R, clearance + sag, sq, ci):
            return None
    return chord, (cx, cy, radius)


def _dedup_keep(points: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    step = np.hypot(*np.diff(points, axis=0).T)
    return points[np.concatenate(([True], step > tol))]
