"""LaserScan-shaped sonar: exact ray casting against the net circle, squares and circles.

One model for the env, the simulator node and the tests. Beam ``i`` points at body angle
``angle_min + i * angle_increment`` (defaults: 72 beams, 0..355 deg in 5 deg steps, as the study's
sensor). A beam reports the distance to the first surface it meets; beyond ``max_range`` it reports
``inf``, as `sensor_msgs/LaserScan` (REP 117) says for "no return". A beam that starts inside an
obstacle or outside the net reports 0.

Speed: the kernels are compiled with numba and cull obstacles that cannot be within range once per
scan (not per beam). They are vectorised over beams and over a batch of vehicles, each vehicle in
its own world (worlds are packed as flat arrays plus offsets).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Sequence

import numba
import numpy as np

from .world import ObstacleArrays, World


@dataclass(frozen=True)
class SonarModel:
    """Geometry and error model of the sonar (REP 117 conventions for out-of-range beams).

    noise_std: Gaussian range noise (m) on returns. dropout: probability that a beam returns no echo
    (reported as ``inf``, the same as out of range).
    """

    n_beams: int = 72
    angle_min: float = 0.0
    angle_increment: float = math.radians(5.0)
    max_range: float = 20.0
    min_range: float = 0.0
    noise_std: float = 0.0
    dropout: float = 0.0

    def __post_init__(self) -> None:
        if self.n_beams < 1:
            raise ValueError("n_beams must be >= 1")
        if not self.max_range > 0:
            raise ValueError("max_range must be > 0")
        if not 0.0 <= self.dropout < 1.0:
            raise ValueError("dropout must be in [0, 1)")
        if self.noise_std < 0:
            raise ValueError("noise_std must be >= 0")

    @cached_property
    def angles(self) -> np.ndarray:
        """Body-frame beam angles (rad), computed once per model."""
        return self.angle_min + self.angle_increment * np.arange(self.n_beams)

    @property
    def angle_max(self) -> float:
        return self.angle_min + self.angle_increment * (self.n_beams - 1)

    def scan(self, world: World, x: float, y: float, yaw: float, t: float = 0.0,
             rng: np.random.Generator | None = None) -> np.ndarray:
        """One scan from pose (x, y, yaw) in ``world`` at time ``t``; shape (n_beams,)."""
        arrs = world.arrays(t)
        out = np.empty(self.n_beams)
        _scan_one(x, y, yaw, self.angles, world.net_radius, arrs.squares, arrs.circles,
                  self.max_range, out)
        return self._corrupt(out, rng)

    def scan_batch(self, worlds: Sequence[World], poses: np.ndarray, t: np.ndarray | float = 0.0,
                   rng: np.random.Generator | None = None) -> np.ndarray:
        """Scans for B vehicles; vehicle b lives in ``worlds[b]`` (or all in ``worlds[0]`` when one
        world is given). ``poses`` is (B, 3) of (x, y, yaw); returns (B, n_beams)."""
        poses = np.ascontiguousarray(poses, dtype=np.float64).reshape(-1, 3)
        packed = PackedWorlds.build(worlds, t, len(poses))
        out = np.empty((len(poses), self.n_beams))
        _scan_batch(poses, self.angles, packed.net_radius, packed.world_of, packed.squares,
                    packed.sq_offsets, packed.circles, packed.ci_offsets, self.max_range, out)
        return self._corrupt(out, rng)

    def _corrupt(self, ranges: np.ndarray, rng: np.random.Generator | None) -> np.ndarray:
        if rng is None or (self.noise_std == 0.0 and self.dropout == 0.0):
            return ranges
        finite = np.isfinite(ranges)
        if self.noise_std > 0:
            noisy = ranges + rng.normal(0.0, self.noise_std, ranges.shape)
            ranges = np.where(finite, np.clip(noisy, self.min_range, None), ranges)
        if self.dropout > 0:
            ranges = np.where(rng.random(ranges.shape) < self.dropout, np.inf, ranges)
        ranges[ranges > self.max_range] = np.inf
        return ranges


@dataclass(frozen=True)
class PackedWorlds:
    """Several worlds as flat arrays plus offsets, so one compiled loop scans them all."""

    net_radius: np.ndarray
    world_of: np.ndarray
    squares: np.ndarray
    sq_offsets: np.ndarray
    circles: np.ndarray
    ci_offsets: np.ndarray

    @staticmethod
    def build(worlds: Sequence[World], t: np.ndarray | float, n_vehicles: int) -> "PackedWorlds":
        worlds = list(worlds)
        times = np.broadcast_to(np.asarray(t, dtype=float), (len(worlds),)) if len(worlds) > 1 \
            else np.asarray([np.asarray(t, dtype=float).reshape(-1)[0]])
        arrs: list[ObstacleArrays] = [w.arrays(float(tt)) for w, tt in zip(worlds, times)]
        if len(worlds) == 1:
            world_of = np.zeros(n_vehicles, dtype=np.int64)
        elif len(worlds) == n_vehicles:
            world_of = np.arange(n_vehicles, dtype=np.int64)
        else:
            raise ValueError("give one world, or one world per vehicle")
        return PackedWorlds(
            net_radius=np.array([w.net_radius for w in worlds], dtype=np.float64),
            world_of=world_of,
            squares=np.concatenate([a.squares for a in arrs]).reshape(-1, 3),
            sq_offsets=np.cumsum([0] + [len(a.squares) for a in arrs]).astype(np.int64),
            circles=np.concatenate([a.circles for a in arrs]).reshape(-1, 3),
            ci_offsets=np.cumsum([0] + [len(a.circles) for a in arrs]).astype(np.int64),
        )


@numba.njit(cache=True, fastmath=False)
def _ray_net(px, py, dx, dy, r):
    b = px * dx + py * dy
    c = px * px + py * py - r * r
    if c >= 0.0:
        return 0.0
    return -b + math.sqrt(b * b - c)


@numba.njit(cache=True, fastmath=False)
def _ray_circle(px, py, dx, dy, cx, cy, r):
    ox, oy = px - cx, py - cy
    c = ox * ox + oy * oy - r * r
    if c <= 0.0:
        return 0.0
    b = ox * dx + oy * dy
    if b >= 0.0:
        return math.inf
    disc = b * b - c
    if disc < 0.0:
        return math.inf
    return -b - math.sqrt(disc)


@numba.njit(cache=True, fastmath=False)
def _ray_square(px, py, dx, dy, cx, cy, h):
    tmin, tmax = -math.inf, math.inf
    lo, hi, p, d = cx - h, cx + h, px, dx
    for axis in range(2):
        if axis == 1:
            lo, hi, p, d = cy - h, cy + h, py, dy
        if d == 0.0:
            if p < lo or p > hi:
                return math.inf
        else:
            t1, t2 = (lo - p) / d, (hi - p) / d
            if t1 > t2:
                t1, t2 = t2, t1
            tmin, tmax = max(tmin, t1), min(tmax, t2)
    if tmax < tmin or tmax < 0.0:
        return math.inf
    return max(tmin, 0.0)


@numba.njit(cache=True, fastmath=False)
def _scan_into(px, py, yaw, angles, net_r, squares, s0, s1, circles, c0, c1, max_range, out, keep):
    # Cull once per scan: an obstacle whose nearest point is beyond range cannot be hit by any beam.
    nk = 0
    for k in range(s0, s1):
        cx, cy, h = squares[k, 0], squares[k, 1], squares[k, 2]
        if math.hypot(cx - px, cy - py) - 1.4142135623730951 * h <= max_range:
            keep[nk] = k
            nk += 1
    nc = 0
    for k in range(c0, c1):
        cx, cy, r = circles[k, 0], circles[k, 1], circles[k, 2]
        if math.hypot(cx - px, cy - py) - r <= max_range:
            keep[nk + nc] = k
            nc += 1
    for i in range(angles.shape[0]):
        a = yaw + angles[i]
        dx, dy = math.cos(a), math.sin(a)
        best = _ray_net(px, py, dx, dy, net_r)
        for j in range(nk):
            k = keep[j]
            t = _ray_square(px, py, dx, dy, squares[k, 0], squares[k, 1], squares[k, 2])
            if t < best:
                best = t
        for j in range(nc):
            k = keep[nk + j]
            t = _ray_circle(px, py, dx, dy, circles[k, 0], circles[k, 1], circles[k, 2])
            if t < best:
                best = t
        out[i] = best if best <= max_range else math.inf


@numba.njit(cache=True)
def _scan_one(px, py, yaw, angles, net_r, squares, circles, max_range, out):
    keep = np.empty(squares.shape[0] + circles.shape[0], dtype=np.int64)
    _scan_into(px, py, yaw, angles, net_r, squares, 0, squares.shape[0], circles, 0,
               circles.shape[0], max_range, out, keep)


@numba.njit(cache=True)
def _scan_batch(poses, angles, net_r, world_of, squares, sq_off, circles, ci_off, max_range, out):
    keep = np.empty(squares.shape[0] + circles.shape[0], dtype=np.int64)
    for b in range(poses.shape[0]):
        w = world_of[b]
        _scan_into(poses[b, 0], poses[b, 1], poses[b, 2], angles, net_r[w], squares, sq_off[w],
                   sq_off[w + 1], circles, ci_off[w], ci_off[w + 1], max_range, out[b], keep)
