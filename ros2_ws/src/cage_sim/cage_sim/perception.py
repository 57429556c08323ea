"""What the shield and the classical baseline know besides the scan: drift and the motion of returns.

Why: a manoeuvre checked in still water is not the manoeuvre flown in a 0.25-0.5 m/s current (the
vehicle drifts 2.5-5 m over a 10 m rollout), and a fish school that swims 0.5 m/s toward the route is
not where the last scan saw it. A real AUV knows its velocity over ground (DVL) and its commanded
velocity through the water, so the drift (their difference) is observable; the motion of returns is
estimated across consecutive scans (``ReturnMotion``). ``Perception`` carries both, in the body frame
at the decision, to the rollouts in ``controller`` and ``shield``: a return ``q`` with ground velocity
``u`` is at ``q + u t`` when the vehicle, flown through the water to ``p(t)``, is at ``p(t) + drift t``;
so the clearance is ``|p(t) + (drift - u) t - q|``. Pure NumPy, the same code offline and in the node.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


def _zeros2() -> np.ndarray:
    return np.zeros(2)


@dataclass
class Perception:
    """Inputs of one decision, all in the body frame at the decision (x forward, y left)."""

    returns: np.ndarray                                   # (K, 2) sonar returns, m
    velocities: np.ndarray | None = None                  # (K, 2) their velocity over ground, m/s (None: static)
    drift: np.ndarray = field(default_factory=_zeros2)   # (2,) velocity over ground - through-water velocity, m/s
    final: bool = False                                   # the waypoint is the mission's goal (the mission
    #                                                       ends on passing through it: nothing after matters)

    def relative(self) -> np.ndarray:
        """(K, 2) velocity of the vehicle's drift relative to each return: ``drift - u``."""
        u = self.velocities if self.velocities is not None else np.zeros_like(self.returns)
        return np.asarray(self.drift, dtype=np.float64)[None, :] - u


def body_drift(v_ground_body, speed: float) -> np.ndarray:
    """Drift from a DVL reading: velocity over ground (body frame) minus the commanded (speed, 0)."""
    v = np.asarray(v_ground_body, dtype=np.float64).reshape(2)
    if not np.isfinite(v).all():
        return np.zeros(2)
    return v - np.array([speed, 0.0])


def to_body(vec_map, yaw: float) -> np.ndarray:
    """A map-frame vector expressed in the body frame of a vehicle at heading ``yaw``."""
    c, s = math.cos(yaw), math.sin(yaw)
    v = np.asarray(vec_map, dtype=np.float64)
    return np.stack([c * v[..., 0] + s * v[..., 1], -s * v[..., 0] + c * v[..., 1]], axis=-1)


def to_map(points_body, pose) -> np.ndarray:
    """Body-frame points to the map frame of a vehicle at ``pose`` (x, y, yaw)."""
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    p = np.asarray(points_body, dtype=np.float64).reshape(-1, 2)
    return np.stack([x + c * p[:, 0] - s * p[:, 1], y + s * p[:, 0] + c * p[:, 1]], axis=1)


@dataclass
class ReturnMotion:
    """Velocity over ground of each return, from two consecutive scans (stateful, one per vehicle).

    Returns are grouped into clusters (neighbouring beams whose points lie within ``join`` m). A
    cluster whose points lie on the previous scan's surface (median distance to the polyline through
    the previous scan's points, map frame, below ``still``) is static: the visible part of a static
    obstacle or of the net shifts as the vehicle moves, so a centroid shift alone would make it
    "move". Otherwise the cluster is matched to the nearest previous centroid within ``gate`` m and
    its centroid's displacement over the elapsed time is its velocity; speeds below ``min_speed`` or
    above ``max_speed`` (a wrong match) count as 0. A velocity is used only when the cluster it was
    matched to had one within ``agree`` m/s at the scan before (0: no such check).

    Why the agreement check: a static obstacle seen from a moving vehicle is hit at other points
    from scan to scan (a small one by one or two beams, a square round its corner), so its cluster
    often leaves the previous scan's surface and its centroid "moves". Along the shielded driver's
    missions in the 0.5 m/s, 3-school cell, 15.5 % of the returns of static obstacles and of the net
    got a velocity (median 0.39 m/s, up to 2 m/s), ten times as many as the returns of fish, and
    the rollouts carried those returns 4 m over a 10 s look-ahead: turns looked blocked, or open,
    that were not. Such false velocities change from scan to scan; a school's flight does not.
    With ``agree = 0.5``: 2.9 % of static returns, and on 1000 missions of each of the hardest
    0.5 m/s cells the shielded driver's collisions fell 4 -> 1 and 12 -> 6, its goals rose 982 ->
    989 and 973 -> 983 (a school's velocity now counts from its third scan on, not its second).
    """

    join: float = 1.0
    gate: float = 2.0
    still: float = 0.15
    min_speed: float = 0.15
    max_speed: float = 2.0
    agree: float = 0.5                     # m/s; > 0: a velocity counts only if the matched cluster's last one agrees
    _prev: np.ndarray | None = None        # (N, 2) map-frame points of the previous scan
    _prev_labels: np.ndarray | None = None
    _prev_t: float = 0.0
    _prev_raw: np.ndarray | None = None    # (M, 2) map-frame raw velocity of each previous cluster (nan: none)
    _prev_cents: np.ndarray | None = None  # (M, 2) map-frame centroid of each previous cluster

    def reset(self) -> None:
        self._prev = None
        self._prev_raw = None
        self._prev_cents = None

    def update(self, points_body: np.ndarray, pose, t: float) -> np.ndarray:
        """(K, 2) body-frame velocity over ground of each of ``points_body`` (in beam order).

        Written over all clusters at once (centroids by ``np.bincount``, one [moving, previous]
        distance table), not one NumPy call per cluster: the same operations on every value, so
        the same velocities, at a fraction of the per-scan cost (a decision's perception)."""
        pts = np.asarray(points_body, dtype=np.float64).reshape(-1, 2)
        world = to_map(pts, pose)
        labels = self._clusters(world)
        n_clusters = int(labels.max()) + 1 if len(labels) else 0
        cents = _centroids(world, labels, n_clusters)
        raw = np.full((n_clusters, 2), np.nan)
        prev, prev_labels, prev_cents, dt, prev_raw = \
            self._prev, self._prev_labels, self._prev_cents, t - self._prev_t, self._prev_raw
        self._prev, self._prev_labels, self._prev_cents, self._prev_t, self._prev_raw = world, labels, cents, t, raw
        if prev is None or len(prev) == 0 or len(pts) == 0 or dt <= 0:
            return np.zeros_like(pts)
        a, b = self._segments(prev, prev_labels)
        moving = np.flatnonzero(_cluster_medians(_point_segment_distance(world, a, b), labels, n_clusters) > self.still)
        if len(moving) == 0:
            return np.zeros_like(pts)
        c = cents[moving]                                                    # [M, 2]
        gap = prev_cents[None, :, :] - c[:, None, :]                         # [M, P, 2]
        d = np.sqrt(np.add.reduce(gap * gap, axis=-1))                       # |prev - c|, as np.linalg.norm
        j = np.argmin(d, axis=1)
        v = (c - prev_cents[j]) / dt
        speed = np.hypot(v[:, 0], v[:, 1])
        matched = (d[np.arange(len(moving)), j] <= self.gate) & (self.min_speed <= speed) & (speed <= self.max_speed)
        raw[moving[matched]] = v[matched]
        used = matched
        if self.agree > 0:   # a previous cluster with no velocity (nan) never agrees
            change = v - prev_raw[j]
            used = matched & (np.hypot(change[:, 0], change[:, 1]) <= self.agree)
        per_cluster = np.zeros((n_clusters, 2))
        per_cluster[moving[used]] = to_body(v[used], pose[2])
        return per_cluster[labels]

    def _segments(self, pts: np.ndarray, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Segments joining consecutive points of one cluster (single points: zero-length)."""
        same = labels[1:] == labels[:-1]
        a = np.concatenate([pts[:-1][same], pts])
        b = np.concatenate([pts[1:][same], pts])
        return a, b

    def _clusters(self, pts: np.ndarray) -> np.ndarray:
        """Label points in beam order: a new cluster starts where a point is > join from the last."""
        labels = np.zeros(len(pts), dtype=int)
        if len(pts) == 0:
            return labels
        labels[1:] = np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1) > self.join)
        if len(pts) > 2 and labels[-1] > 0 and np.hypot(*(pts[0] - pts[-1])) <= self.join:
            labels[labels == labels[-1]] = 0                     # a 360 deg scan wraps around
        return labels      # 0..n-1, each present (the wrapped last label was the largest)


def _centroids(points: np.ndarray, labels: np.ndarray, n: int) -> np.ndarray:
    """(n, 2) mean of ``points`` over each label 0..n-1 (each label present): the sums of
    ``np.bincount`` are made in point order as ``points[labels == k].mean(axis=0)`` makes them."""
    counts = np.bincount(labels, minlength=n)
    return np.stack([np.bincount(labels, points[:, 0], n), np.bincount(labels, points[:, 1], n)], axis=1) \
        / counts[:, None]


def _cluster_medians(values: np.ndarray, labels: np.ndarray, n: int) -> np.ndarray:
    """(n,) median of ``values`` over each label 0..n-1 (each label present): one sort instead of
    a ``np.median`` per cluster (the same values: the middle one, or the mean of the two middle)."""
    order = np.lexsort((values, labels))
    counts = np.bincount(labels, minlength=n)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    v = values[order]
    hi = v[starts + counts // 2]
    lo = v[starts + np.maximum(counts - 1, 0) // 2]
    return np.where(counts % 2 == 1, hi, (lo + hi) / 2)


def _point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N,) distance from each point to the nearest of the segments a[i]-b[i]. Written per
    coordinate ([N, S] arrays, not [N, S, 2] with sums over the last axis) and with the square root
    after the minimum: the same operations on every element, so the same values, in a third of
    the time."""
    abx, aby = b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]
    n2 = np.maximum(abx * abx + aby * aby, 1e-12)
    px, py = p[:, 0, None], p[:, 1, None]
    s = np.clip(((px - a[:, 0]) * abx + (py - a[:, 1]) * aby) / n2, 0.0, 1.0)   # [N, S]
    dx = px - (a[:, 0] + s * abx)
    dy = py - (a[:, 1] + s * aby)
    return np.sqrt((dx * dx + dy * dy).min(axis=1))


def perceive(returns_body: np.ndarray, pose, t: float, drift_body=None, final: bool = False,
             motion: ReturnMotion | None = None) -> Perception:
    """One decision's ``Perception``: the scan's returns (body frame), their velocities estimated by
    ``motion`` against the previous scan (None: taken as static), the drift (body frame, m/s) and
    whether the waypoint is the goal. The evaluator and the policy node both build it this way."""
    pts = np.asarray(returns_body, dtype=np.float64).reshape(-1, 2)
    vel = motion.update(pts, pose, t) if motion is not None else None
    drift = np.zeros(2) if drift_body is None else np.asarray(drift_body, dtype=np.float64).reshape(2)
    return Perception(pts, vel, np.where(np.isfinite(drift), drift, 0.0), bool(final))
