"""Fish schools that keep away from the vehicle and close in again: a seeded, stateful update step.

Why: fish react to vehicles (thruster noise, sudden moves: SINTEF/NTNU 2024, ../shared/REFERENCE.md); a
school that was in front of the sonar a second ago is elsewhere now. A policy or shield that treats
returns as static is wrong about them, and the old to-and-fro oscillation never reacted to the vehicle.

Each school is a circle (radius ``radius``) with a home point. Every update: if the vehicle is within
``flee_radius`` of the school's edge it swims straight away at ``flee_speed``; otherwise it drifts back
toward home at ``return_speed`` while wandering on a slow circle of ``wander`` m about home. Schools stay
``margin`` m inside the nominal net. Deterministic given the seed (the only randomness is each school's
wander phase, drawn once). The state is a (K, 2) array; ``circles()`` packs it for the sonar.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


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

    def __len__(self) -> int:
        return len(self.schools)

    def target(self, t: float) -> np.ndarray:
        """Where each school would be undisturbed at time ``t``: on its wander circle about home."""
        w = np.array([s.wander for s in self.schools])
        per = np.array([s.wander_period for s in self.schools])
        a = self.phase + 2 * math.pi * t / np.maximum(per, 1e-9)
        return self.home + w[:, None] * np.c_[np.cos(a), np.sin(a)]

    def step(self, dt: float, vehicle_xy, substeps: int = 4) -> np.ndarray:
        """Advance ``dt`` seconds with the vehicle at ``vehicle_xy``; returns the (K, 2) positions."""
        if not len(self.schools) or dt <= 0:
            self.t += max(dt, 0.0)
            return self.pos
        v = np.asarray(vehicle_xy, dtype=float)
        h = dt / substeps
        for _ in range(substeps):
            self.t += h
            away = self.pos - v
            dist = np.hypot(away[:, 0], away[:, 1])
            for k, s in enumerate(self.schools):
                if dist[k] - s.radius < s.flee_radius:
                    u = away[k] / dist[k] if dist[k] > 1e-9 else np.array([1.0, 0.0])
                    self.pos[k] += s.flee_speed * h * u
                else:
                    to = self.target(self.t)[k] - self.pos[k]
                    n = math.hypot(*to)
                    if n > 1e-9:
                        self.pos[k] += min(n, s.return_speed * h) * to / n
            # stay inside the net
            r = np.hypot(self.pos[:, 0], self.pos[:, 1])
            lim = self.net_radius - self.radius - self.margin
            over = r > lim
            if np.any(over):
                self.pos[over] *= (lim[over] / r[over])[:, None]
        return self.pos

    def circles(self) -> np.ndarray:
        """(K, 3) rows of (cx, cy, radius): the form the sonar kernels take."""
        return np.c_[self.pos, self.radius].reshape(-1, 3)
