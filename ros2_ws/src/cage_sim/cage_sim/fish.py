"""Fish schools that keep away from the vehicle and close in again: a seeded, stateful update step.

Why: fish react to vehicles (thruster noise, sudden moves: SINTEF/NTNU 2024, ../shared/REFERENCE.md); a
school that was in front of the sonar a second ago is elsewhere now. A policy or shield that treats
returns as static is wrong about them, and the old to-and-fro oscillation never reacted to the vehicle.

Each school is a circle (radius ``radius``) with a home point. Every update: once the vehicle comes within
``flee_radius`` of the school's edge it swims straight away at ``flee_speed`` until the vehicle is
``CALM`` (1.5) times that far; otherwise it drifts back
toward home at ``return_speed`` while wandering on a slow circle of ``wander`` m about home. Schools stay
``margin`` m inside the nominal net. Deterministic given the seed (the only randomness is each school's
wander phase, drawn once). The state is a (K, 2) array; ``circles()`` packs it for the sonar.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

CALM = 1.5   # a fleeing school stops fleeing at CALM * flee_radius (hysteresis: no dithering at the edge)


@dataclass(frozen=True)
class FishSchool:
    """Scenario-file description of one school (map frame, metres, m/s, seconds)."""

    x: float
    y: float
    radius: float = 1.5
    flee_radius: float = 4.0
    flee_speed: float = 0.8
    return_speed: float = 0.2
    wander: float = 2.0
    wander_period: float = 60.0

    def __post_init__(self) -> None:
        for name in ("x", "y"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"school {name} must be finite, got {getattr(self, name)!r}")
        if not (self.radius > 0 and math.isfinite(self.radius)):
            raise ValueError(f"school radius must be > 0, got {self.radius!r}")
        for name in ("flee_radius", "flee_speed", "return_speed", "wander"):
            v = getattr(self, name)
            if not (v >= 0 and math.isfinite(v)):
                raise ValueError(f"school {name} must be >= 0 (a speed or distance), got {v!r}")
        if not self.wander_period > 0:
            raise ValueError(f"school wander_period must be > 0, got {self.wander_period!r}")


class FishState:
    """Positions of a world's schools over one episode; ``step`` moves them given the vehicle position."""

    def __init__(self, schools: tuple[FishSchool, ...], net_radius: float, seed: int = 0, margin: float = 1.0):
        self.schools = tuple(schools)
        self.net_radius, self.margin = net_radius, margin
        self.home = np.array([[s.x, s.y] for s in self.schools], dtype=float).reshape(-1, 2)
        self.pos = self.home.copy()
        self.radius = np.array([s.radius for s in self.schools], dtype=float)
        self.phase = np.random.default_rng(seed).uniform(0, 2 * math.pi, len(self.schools))
        self.t = 0.0
        self._wander = np.array([s.wander for s in self.schools], dtype=float)
        self._period = np.array([s.wander_period for s in self.schools], dtype=float)
        self._flee_r = np.array([s.flee_radius for s in self.schools], dtype=float)
        self._flee_v = np.array([s.flee_speed for s in self.schools], dtype=float)
        self._ret_v = np.array([s.return_speed for s in self.schools], dtype=float)
        self._limit = net_radius - self.radius - margin
        self.fleeing = np.zeros(len(self.schools), dtype=bool)

    def __len__(self) -> int:
        return len(self.schools)

    def target(self, t: float) -> np.ndarray:
        """Where each school would be undisturbed at time ``t``: on its wander circle about home."""
        a = self.phase + 2 * math.pi * t / self._period
        return self.home + self._wander[:, None] * np.stack([np.cos(a), np.sin(a)], axis=1)

    def step(self, dt: float, vehicle_xy, substeps: int = 4) -> np.ndarray:
        """Advance ``dt`` seconds with the vehicle at ``vehicle_xy``; returns the (K, 2) positions.
        Plain floats per school: a handful of schools, where NumPy's per-call cost would dominate."""
        if not len(self.schools) or dt <= 0:
            self.t += max(dt, 0.0)
            return self.pos
        vx, vy = float(vehicle_xy[0]), float(vehicle_xy[1])
        h = dt / substeps
        pos = self.pos.tolist()
        fleeing = self.fleeing.tolist()
        for k, s in enumerate(self.schools):
            x, y = pos[k]
            hx, hy, ph, lim = self.home[k, 0], self.home[k, 1], self.phase[k], self._limit[k]
            t = self.t
            for _ in range(substeps):
                t += h
                ax, ay = x - vx, y - vy
                dist = math.hypot(ax, ay)
                edge = dist - s.radius
                fleeing[k] = edge < s.flee_radius or (fleeing[k] and edge < CALM * s.flee_radius)
                if fleeing[k]:
                    ux, uy = (ax / dist, ay / dist) if dist > 1e-9 else (1.0, 0.0)
                    x, y = x + s.flee_speed * h * ux, y + s.flee_speed * h * uy
                else:
                    a = ph + 2 * math.pi * t / s.wander_period
                    tx, ty = hx + s.wander * math.cos(a) - x, hy + s.wander * math.sin(a) - y
                    n = math.hypot(tx, ty)
                    if n > 1e-9:
                        f = min(n, s.return_speed * h) / n
                        x, y = x + f * tx, y + f * ty
                r = math.hypot(x, y)
                if r > lim:                                   # stay inside the net
                    x, y = x * lim / r, y * lim / r
            pos[k] = [x, y]
        self.t += dt
        self.pos = np.array(pos, dtype=float).reshape(-1, 2)
        self.fleeing = np.array(fleeing, dtype=bool)
        return self.pos

    def circles(self) -> np.ndarray:
        """(K, 3) rows of (cx, cy, radius): the form the sonar kernels take."""
        return np.concatenate([self.pos, self.radius[:, None]], axis=1)
