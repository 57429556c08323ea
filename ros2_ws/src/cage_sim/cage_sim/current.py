"""Water current inside the pen: a uniform flow plus a few slowly varying sinusoid modes, speed capped.

Why: a real site's flow is neither still nor uniform (0.1 m/s to over 1 m/s at exposed sites; inside a
pen about 0.8-0.9 of the outside flow, Lader & Enerhaug 2005; ../shared/REFERENCE.md). A vehicle that
only ever saw a uniform drift learns to trim for one vector; a field that changes over metres and
minutes makes the drift something to observe (velocity over ground), not to memorise.

Convention: ``velocity(x, y, t)`` is the water velocity INSIDE the pen (map frame, m/s), the velocity the
vehicle drifts with. The outside (free-stream) flow that loads the net is ``uniform / INSIDE_FACTOR``
(see net.py). Each mode adds ``amplitude * sin(kx x + ky y - omega t + phase)`` along its own
direction; the total speed is capped at ``cap`` (the vector is scaled down, its direction kept).
Pure NumPy, no ROS.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

INSIDE_FACTOR = 0.85   # flow inside a pen / outside (0.8-0.9, Lader & Enerhaug 2005)


@dataclass(frozen=True)
class CurrentMode:
    """One slowly varying component: ``(ax, ay) * sin(kx*x + ky*y - omega*t + phase)`` (m/s)."""

    ax: float
    ay: float
    kx: float = 0.0
    ky: float = 0.0
    omega: float = 0.0
    phase: float = 0.0

    def __post_init__(self) -> None:
        for name in ("ax", "ay", "kx", "ky", "omega", "phase"):
            v = getattr(self, name)
            if not math.isfinite(v):
                raise ValueError(f"current mode {name} must be finite, got {v!r}")

    @property
    def amplitude(self) -> float:
        return math.hypot(self.ax, self.ay)


@dataclass(frozen=True)
class CurrentField:
    """Uniform flow + modes, capped at ``cap`` m/s. With no modes the field is exactly uniform (and the
    vehicle model's closed form stays exact)."""

    uniform: tuple[float, float] = (0.0, 0.0)
    modes: tuple[CurrentMode, ...] = ()
    cap: float = math.inf

    def __post_init__(self) -> None:
        object.__setattr__(self, "uniform", (float(self.uniform[0]), float(self.uniform[1])))
        object.__setattr__(self, "modes", tuple(self.modes))
        if not all(math.isfinite(v) for v in self.uniform):
            raise ValueError(f"current must be finite, got {self.uniform!r}")
        if not self.cap > 0:
            raise ValueError(f"current cap must be > 0, got {self.cap!r}")

    @property
    def is_uniform(self) -> bool:
        return not self.modes and math.hypot(*self.uniform) <= self.cap

    @property
    def max_speed(self) -> float:
        """Upper bound of the speed anywhere, any time (what validation compares with the vehicle's speed)."""
        return min(self.cap, math.hypot(*self.uniform) + sum(m.amplitude for m in self.modes))

    def velocity(self, x, y, t=0.0):
        """Water velocity at (x, y, t): scalars give a (vx, vy) tuple, arrays give two arrays."""
        scalar = (isinstance(x, float) and isinstance(y, float)) or (np.ndim(x) == 0 and np.ndim(y) == 0)
        if scalar and self.modes:
            vx, vy = self.uniform
            for m in self.modes:
                s = math.sin(m.kx * x + m.ky * y - m.omega * t + m.phase)
                vx += m.ax * s
                vy += m.ay * s
            sp = math.hypot(vx, vy)
            if sp > self.cap:
                vx, vy = vx * self.cap / sp, vy * self.cap / sp
            return vx, vy
        if self.is_uniform:
            if scalar:
                return self.uniform
            shape = np.broadcast(np.asarray(x), np.asarray(y)).shape
            return np.full(shape, self.uniform[0]), np.full(shape, self.uniform[1])
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        vx = np.full(np.broadcast(x, y).shape, self.uniform[0])
        vy = np.full_like(vx, self.uniform[1])
        for m in self.modes:
            s = np.sin(m.kx * x + m.ky * y - m.omega * t + m.phase)
            vx = vx + m.ax * s
            vy = vy + m.ay * s
        sp = np.hypot(vx, vy)
        scale = np.where(sp > self.cap, self.cap / np.maximum(sp, 1e-12), 1.0)
        vx, vy = vx * scale, vy * scale
        if scalar:
            return float(vx), float(vy)
        return vx, vy


def random_field(rng: np.random.Generator, speed: float, n_modes: int = 2, variation: float = 0.2,
                 wavelength: tuple[float, float] = (30.0, 120.0), period: tuple[float, float] = (60.0, 600.0)
                 ) -> CurrentField:
    """A uniform flow of ``speed`` m/s in a random direction plus ``n_modes`` modes whose amplitudes sum
    to ``variation * speed`` (wavelengths 30-120 m, periods 1-10 min: slow next to a 1 m/s vehicle);
    capped at ``speed * (1 + variation)``."""
    ang = rng.uniform(-math.pi, math.pi)
    uniform = (speed * math.cos(ang), speed * math.sin(ang))
    modes = []
    for _ in range(n_modes if speed > 0 and variation > 0 else 0):
        a, k_dir = rng.uniform(-math.pi, math.pi), rng.uniform(-math.pi, math.pi)
        amp = variation * speed / n_modes
        k = 2 * math.pi / rng.uniform(*wavelength)
        modes.append(CurrentMode(amp * math.cos(a), amp * math.sin(a), k * math.cos(k_dir), k * math.sin(k_dir),
                                 2 * math.pi / rng.uniform(*period), rng.uniform(0, 2 * math.pi)))
    return CurrentField(uniform, tuple(modes), cap=max(speed * (1 + variation), 1e-9) if modes else math.inf)
