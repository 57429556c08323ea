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


def _unit(v: np.ndarray) -> np.ndarray:
    return v / math.hypot(v[0], v[1])


def _cross(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def merge_corners(points: np.ndarray, radius: float, max_turn: float = math.radians(170.0)) -> np.ndarray | None:
    """Corners so that every fillet of ``radius`` fits on its legs, or None where that needs merging
    an S-bend or a turn sharper than ``max_turn`` (no corner point exists)."""
    pts = [np.asarray(p, dtype=float) for p in _dedup(points)]
    changed = True
    while changed and len(pts) > 2:
        changed = False
        t = [0.0] + [_tangent_length(pts[i - 1], pts[i], pts[i + 1], radius) for i in range(1, len(pts) - 1)] + [0.0]
        for i in range(len(pts) - 1):
            leg = math.dist(pts[i], pts[i + 1])
            if t[i] + t[i + 1] <= leg + 1e-12:
                continue
            if i == 0 or i + 1 == len(pts) - 1:
                return None  # the first or last leg is too short for its fillet
            # merge corners i and i+1 into the intersection of legs (i-1, i) and (i+1, i+2)
            a, b = pts[i - 1], pts[i]
            c, d = pts[i + 1], pts[i + 2]
            u, w = _unit(b - a), _unit(d - c)
            turn1, turn2 = _cross(b - a, c - b), _cross(c - b, d - c)
            den = _cross(u, w)
            if turn1 * turn2 < 0 or abs(den) < 1e-12 or math.acos(max(-1.0, min(1.0, float(u @ w)))) > max_turn:
                return None
            s = _cross(c - a, w) / den
            if s <= 0:
                return None
            pts[i:i + 2] = [a + s * u]
            changed = True
            break
    return np.asarray(pts)


def _tangent_length(a, b, c, radius) -> float:
    u, w = _unit(b - a), _unit(c - b)
    theta = math.acos(max(-1.0, min(1.0, float(u @ w))))
    return radius * math.tan(0.5 * theta)


def _dedup(points: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    pts = np.asarray(points, dtype=float)[:, :2]
    keep = [0]
    for i in range(1, len(pts)):
        if math.dist(pts[i], pts[keep[-1]]) > tol:
            keep.append(i)
    out = pts[keep]
    # drop collinear interior points (zero turn)
    if len(out) > 2:
        k = [0]
        for i in range(1, len(out) - 1):
            if abs(_cross(out[i] - out[k[-1]], out[i + 1] - out[i])) > 1e-12 * math.dist(out[i], out[k[-1]]) \
                    * math.dist(out[i + 1], out[i]) or float((out[i] - out[k[-1]]) @ (out[i + 1] - out[i])) < 0:
                k.append(i)
        k.append(len(out) - 1)
        out = out[k]
    return out


def fillet(points: np.ndarray, kmap: KnownMap, clearance: float, radius: float,
           spacing: float = 0.5) -> tuple[np.ndarray, list[tuple[float, float, float]]] | None:
    """(waypoints, arcs): the polyline with every corner rounded, arcs as chords ``spacing``
    apart, and each arc as (centre x, centre y, radius); None when a fillet does not fit or breaks
    the clearance. Straight legs are returned as their two ends (the caller resamples them)."""
    corners = merge_corners(points, radius)
    if corners is None:
        return None
    args = (kmap.net_radius, clearance, kmap.squares, kmap.circles)
    out = [corners[0]]
    arcs: list[tuple[float, float, float]] = []
    for i in range(1, len(corners) - 1):
        a, b, c = corners[i - 1], corners[i], corners[i + 1]
        u, w = _unit(b - a), _unit(c - b)
        theta = math.acos(max(-1.0, min(1.0, float(u @ w))))
        t = radius * math.tan(0.5 * theta)
        p, q = b - t * u, b + t * w
        side = 1.0 if _cross(u, w) > 0 else -1.0          # left turn: centre on the left
        centre = p + side * radius * np.array([-u[1], u[0]])
        a0 = math.atan2(p[1] - centre[1], p[0] - centre[0])
        n = max(1, int(math.ceil(radius * theta / spacing)))
        sag = (radius * theta / n) ** 2 / (8.0 * radius)
        chord = [centre + radius * np.array([math.cos(a0 + side * theta * k / n), math.sin(a0 + side * theta * k / n)])
                 for k in range(n + 1)]
        chord[0], chord[-1] = p, q
        if not segment_valid(out[-1][0], out[-1][1], p[0], p[1], *args):
            return None
        for s0, s1 in zip(chord[:-1], chord[1:]):
            if not segment_valid(s0[0], s0[1], s1[0], s1[1], args[0], clearance + sag, args[2], args[3]):
                return None
        out.extend(chord)
        arcs.append((float(centre[0]), float(centre[1]), radius))
    end = corners[-1]
    if not segment_valid(out[-1][0], out[-1][1], end[0], end[1], *args):
        return None
    out.append(end)
    return _dedup_keep(np.asarray(out)), arcs


def _dedup_keep(points: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    step = np.hypot(*np.diff(points, axis=0).T)
    return points[np.concatenate(([True], step > tol))]
