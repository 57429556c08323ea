"""Memory of what the sonar has seen: returns of the last T seconds as map points, re-projected as an
egocentric 360 deg min-range histogram.

Why: a forward-looking or a mechanical scanning sonar does not see what is beside or behind the vehicle
now; a policy that only gets the latest scan forgets an obstacle the moment it leaves the sector, and
turns into it. Keeping returns as map-frame points (the pose is known: INS/DVL) and re-projecting them
into the body frame at each decision gives the policy, and the shield's rollouts, a fixed-size picture
of everything seen lately, whatever the number of obstacles (the study's open question).
Cleared returns: the memory also marks the returns the sonar has since seen past (a beam's echo, or
its silence, farther out along the same bearing) and those the vehicle has since passed through
(within ``SWEEP_RADIUS`` of its track). Such a return is no longer there: a fish school that fled
(schools flee at up to 0.8 m/s, so a 10 s memory holds a trail of one up to 8 m long, often along the
vehicle's way), or a range kept as the nearest of ten noisy ones. The policies read
every remembered return (what they were trained on); the shield and the baseline with
``remembered="cleared"`` read only the uncleared ones (``histogram(..., include_cleared=False)``).
The histogram has ``bins`` sectors, bin ``i`` centred on body angle ``i * 360 / bins`` (0 = ahead, left
positive, as the study's beams); each holds the nearest remembered return in it, ``inf`` if none.
``ObservationBuilder`` (observation.py) owns one per vehicle; the env and policy_node call it alike.
"""
from __future__ import annotations

import math

import numpy as np


# m: a remembered return this near the vehicle's track since is one it passed through (below the
# world's 0.5 m safety radius: a real one that near would have been a collision).
SWEEP_RADIUS = 0.4
# m: a return counts as seen past when a beam over it reaches this much farther (range noise is
# 0.05 m; a beam's cone spreads over an obstacle's face at a slant).
SEE_PAST_MARGIN = 0.3


class ReturnMemory:
    """Sonar returns of the last ``horizon`` seconds as map-frame points (at most ``max_points``,
    newest kept), each with a flag: cleared since (``clear_seen_past``, ``clear_swept``)."""

    def __init__(self, bins: int = 72, horizon: float = 10.0, max_points: int = 4096):
        if bins < 1:
            raise ValueError(f"memory bins must be >= 1, got {bins!r}")
        if not horizon > 0:
            raise ValueError(f"memory horizon must be > 0 s, got {horizon!r}")
        self.bins, self.horizon, self.max_points = int(bins), float(horizon), int(max_points)
        self.reset()

    def reset(self) -> None:
        self.points = np.zeros((0, 2))
        self.stamps = np.zeros(0)
        self.cleared = np.zeros(0, dtype=bool)

    def __len__(self) -> int:
        return len(self.stamps)

    def add(self, ranges: np.ndarray, angles: np.ndarray, origins: np.ndarray, stamps: np.ndarray) -> None:
        """Add beams' returns: body angle ``angles[k]`` and range ``ranges[k]`` measured from pose
        ``origins[k]`` (x, y, yaw) at time ``stamps[k]``. No return (inf/NaN) and 0 are skipped."""
        r = np.asarray(ranges, dtype=float)
        ok = np.isfinite(r) & (r > 0)
        if not np.any(ok):
            return
        o = np.asarray(origins, dtype=float).reshape(-1, 3)[ok]
        a = o[:, 2] + np.asarray(angles, dtype=float)[ok]
        pts = o[:, :2] + r[ok, None] * np.stack([np.cos(a), np.sin(a)], axis=1)
        self.points = np.concatenate([self.points, pts])[-self.max_points:]
        self.stamps = np.concatenate([self.stamps, np.asarray(stamps, dtype=float)[ok]])[-self.max_points:]
        self.cleared = np.concatenate([self.cleared, np.zeros(len(pts), dtype=bool)])[-self.max_points:]

    def clear_seen_past(self, ranges: np.ndarray, angles: np.ndarray, origins: np.ndarray, half_width: float,
                        max_range: float, margin: float = SEE_PAST_MARGIN) -> None:
        """Mark the remembered returns that beams now see past: within a beam's cone (``half_width``
        rad either side of body angle ``angles[k]`` from pose ``origins[k]``) and nearer than its
        range ``ranges[k]`` less ``margin``. No return (inf) sees past to ``max_range``; a NaN or
        non-positive range says nothing. Call before ``add``ing the same beams."""
        if not len(self.stamps):
            return
        r = np.asarray(ranges, dtype=float)
        reach = np.where(np.isinf(r) & (r > 0), max_range, np.where(np.isfinite(r) & (r > 0), r, 0.0))
        use = reach > margin
        if not np.any(use):
            return
        o = np.asarray(origins, dtype=float).reshape(-1, 3)[use]
        axes, reach = o[:, 2] + np.asarray(angles, dtype=float)[use], reach[use]
        if np.all(o == o[0]):
            # One origin (an electronic sonar): each point's bearing and range once ([1, C]), and
            # only the points some beam reaches past; the same values as from every beam's origin.
            d = self.points - o[0, :2]
            rng = np.hypot(d[:, 0], d[:, 1])
            cand = np.flatnonzero(rng < reach.max() - margin)
            bearing, rng = np.arctan2(d[cand, 1], d[cand, 0])[None, :], rng[cand][None, :]
        else:                                             # each beam from its own origin: [K, M]
            cand = slice(None)
            d = self.points[None, :, :] - o[:, None, :2]
            bearing, rng = np.arctan2(d[..., 1], d[..., 0]), np.hypot(d[..., 0], d[..., 1])
        off = np.abs((bearing - axes[:, None] + math.pi) % (2 * math.pi) - math.pi)
        past = (off <= half_width) & (rng < reach[:, None] - margin)
        self.cleared[cand] |= past.any(axis=0)

    def clear_swept(self, start, end, radius: float = SWEEP_RADIUS) -> None:
        """Mark the remembered returns within ``radius`` of the vehicle's track from ``start`` to
        ``end`` (x, y): where it has been, nothing is."""
        if not len(self.stamps):
            return
        a, b = np.asarray(start, dtype=float)[:2], np.asarray(end, dtype=float)[:2]
        ab = b - a
        s = np.clip((self.points - a) @ ab / max(float(ab @ ab), 1e-12), 0.0, 1.0)
        gap = self.points - (a + s[:, None] * ab)
        self.cleared |= np.hypot(gap[:, 0], gap[:, 1]) < radius

    def prune(self, t: float) -> None:
        """Forget returns older than ``horizon`` at time ``t``."""
        keep = self.stamps >= t - self.horizon
        if not np.all(keep):
            self.points, self.stamps, self.cleared = self.points[keep], self.stamps[keep], self.cleared[keep]

    @property
    def angles(self) -> np.ndarray:
        """Body-frame bin centres (rad)."""
        return np.arange(self.bins) * (2 * math.pi / self.bins)

    def body_points(self, x: float, y: float, yaw: float) -> np.ndarray:
        """(K, 2) remembered returns in the body frame at pose (x, y, yaw) (x forward, y left): what a
        shield or a baseline rolls its manoeuvres out against, beside and behind the vehicle too."""
        d = self.points - (x, y)
        c, s = np.cos(yaw), np.sin(yaw)
        return np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1)

    def histogram(self, x: float, y: float, yaw: float, include_cleared: bool = True) -> np.ndarray:
        """(bins,) nearest remembered return per body-frame sector from pose (x, y, yaw); inf if
        none. ``include_cleared=False``: without the returns marked cleared."""
        out = np.full(self.bins, np.inf)
        pts = self.points if include_cleared else self.points[~self.cleared]
        if not len(pts):
            return out
        d = pts - (x, y)
        rng = np.hypot(d[:, 0], d[:, 1])
        rel = (np.arctan2(d[:, 1], d[:, 0]) - yaw) % (2 * math.pi)
        idx = np.floor(rel / (2 * math.pi / self.bins) + 0.5).astype(np.int64) % self.bins
        np.minimum.at(out, idx, rng)
        return out
