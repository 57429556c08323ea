"""Memory of what the sonar has seen: returns of the last T seconds as map points, re-projected as an
egocentric 360 deg min-range histogram.

Why: a forward-looking or a mechanical scanning sonar does not see what is beside or behind the vehicle
now; a policy that only gets the latest scan forgets an obstacle the moment it leaves the sector, and
turns into it. Keeping returns as map-frame points (the pose is known: INS/DVL) and re-projecting them
into the body frame at each decision gives the policy, and the shield's rollouts, a fixed-size picture
of everything seen lately, whatever the number of obstacles (the study's open question).
The histogram has ``bins`` sectors, bin ``i`` centred on body angle ``i * 360 / bins`` (0 = ahead, left
positive, as the study's beams); each holds the nearest remembered return in it, ``inf`` if none.
``ObservationBuilder`` (observation.py) owns one per vehicle; the env and policy_node call it alike.
"""
from __future__ import annotations

import math

import numpy as np


class ReturnMemory:
    """Sonar returns of the last ``horizon`` seconds as map-frame points (at most ``max_points``, newest kept)."""

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

    def prune(self, t: float) -> None:
        """Forget returns older than ``horizon`` at time ``t``."""
        keep = self.stamps >= t - self.horizon
        if not np.all(keep):
            self.points, self.stamps = self.points[keep], self.stamps[keep]

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

    def histogram(self, x: float, y: float, yaw: float) -> np.ndarray:
        """(bins,) nearest remembered return per body-frame sector from pose (x, y, yaw); inf if none."""
        out = np.full(self.bins, np.inf)
        if not len(self.stamps):
            return out
        d = self.points - (x, y)
        rng = np.hypot(d[:, 0], d[:, 1])
        rel = (np.arctan2(d[:, 1], d[:, 0]) - yaw) % (2 * math.pi)
        idx = np.floor(rel / (2 * math.pi / self.bins) + 0.5).astype(np.int64) % self.bins
        np.minimum.at(out, idx, rng)
        return out
