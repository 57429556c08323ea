"""The net wall as the current shapes it: a polar radius ``r(theta)`` used by collision and the sonar.

Why: full-scale pens lose about 20 % of their volume at 0.13 m/s and about 40 % at 0.35-0.5 m/s (Lader et
al. 2008; SINTEF full scale: 40 % above 0.5 m/s; ../shared/REFERENCE.md): the upstream wall is pushed in.
The planner's map keeps the nominal circle (nobody surveys the net every tide); the sonar and the
collision test see the deformed wall, so the reactive layer must keep off a wall that is not where
the map says.

Model (2D, horizontal slice): ``r(theta) = R * (1 - a * (1 + cos(theta - theta_up)) / 2)`` where
``theta_up`` is the direction the flow comes FROM (the upstream side: pushed in most), the downstream
wall stays at R. Its area loss is exactly ``a - 3 a^2 / 8``, so ``a`` is solved in closed form from the
wanted loss. We apply the measured VOLUME loss to the slice's area: harsher than reality (part of the
volume is lost by the bottom lifting), which is the side to err on for a collision test.
The loss follows the outside flow (``inside current / INSIDE_FACTOR``) through ``LOSS_TABLE``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .current import INSIDE_FACTOR

# (outside flow m/s, area loss): Lader et al. 2008 (0.13 -> 20 %, 0.35 -> 40 %), SINTEF (40 % above 0.5).
LOSS_TABLE = ((0.0, 0.0), (0.13, 0.20), (0.35, 0.40), (1.0, 0.40))
MAX_LOSS = 0.5
N_VERTICES = 180   # the wall as a polygon, 2 deg per edge: chords within 5 mm of the 30 m curve


def loss_for_current(inside_speed: float) -> float:
    """Area loss fraction for a current of ``inside_speed`` m/s measured inside the pen."""
    if not inside_speed >= 0:
        raise ValueError(f"current speed must be >= 0, got {inside_speed!r}")
    xs, ys = zip(*LOSS_TABLE)
    return float(np.interp(inside_speed / INSIDE_FACTOR, xs, ys))


@dataclass(frozen=True)
class NetShape:
    """Nominal radius ``radius``; ``loss`` the area fraction lost (0 = the circle); ``upstream`` the map
    angle (rad) of the wall facing the flow."""

    radius: float = 30.0
    loss: float = 0.0
    upstream: float = 0.0

    def __post_init__(self) -> None:
        if not (self.radius > 0 and math.isfinite(self.radius)):
            raise ValueError(f"net_radius must be a positive number, got {self.radius!r}")
        if not 0.0 <= self.loss <= MAX_LOSS:
            raise ValueError(f"net deformation must be an area loss in [0, {MAX_LOSS}], got {self.loss!r}")
        if not math.isfinite(self.upstream):
            raise ValueError(f"net upstream angle must be finite, got {self.upstream!r}")

    @staticmethod
    def from_current(radius: float, current: tuple[float, float], loss: float | None = None) -> "NetShape":
        """The net under a uniform ``current`` (inside the pen); ``loss`` None = from ``LOSS_TABLE``."""
        speed = math.hypot(*current)
        if loss is None:
            loss = loss_for_current(speed)
        upstream = math.atan2(-current[1], -current[0]) if speed > 0 else 0.0
        return NetShape(radius, loss, upstream)

    @property
    def deformed(self) -> bool:
        return self.loss > 0.0

    @cached_property
    def push(self) -> float:
        """``a`` of the model: fraction of R the upstream wall is pushed in (solves a - 3a^2/8 = loss)."""
        return (1.0 - math.sqrt(1.0 - 1.5 * self.loss)) / 0.75

    def r(self, theta, t: float = 0.0):
        """Wall radius (m) at map angle(s) ``theta`` (static in time: the uniform flow sets it)."""
        return self.radius * (1.0 - self.push * 0.5 * (1.0 + np.cos(np.asarray(theta) - self.upstream)))

    def inward(self, theta: float, distance: float) -> tuple[float, float]:
        """The point ``distance`` m inside the wall along its inward normal at map angle ``theta`` (a
        goal "2.5 m from the net" is 2.5 m from the nearest wall point, not 2.5 m along the radius)."""
        r = float(self.r(theta))
        dr = self.radius * self.push * 0.5 * math.sin(theta - self.upstream)
        tx, ty = dr * math.cos(theta) - r * math.sin(theta), dr * math.sin(theta) + r * math.cos(theta)
        n = math.hypot(tx, ty)
        return r * math.cos(theta) - distance * ty / n, r * math.sin(theta) + distance * tx / n

    @property
    def min_radius(self) -> float:
        return self.radius * (1.0 - self.push)

    @cached_property
    def polygon(self) -> np.ndarray:
        """(N_VERTICES, 2) wall vertices at 2 deg steps from angle 0 (what the ray kernel and collision use);
        (0, 2) for the nominal circle, which they treat exactly."""
        if not self.deformed:
            return np.zeros((0, 2))
        th = np.arange(N_VERTICES) * (2 * math.pi / N_VERTICES)
        rr = self.r(th)
        return np.ascontiguousarray(np.c_[rr * np.cos(th), rr * np.sin(th)])

    def area_loss(self) -> float:
        """Measured area loss of the polygon (tests compare it with ``loss``)."""
        if not self.deformed:
            return 0.0
        p = self.polygon
        q = np.roll(p, -1, axis=0)
        area = 0.5 * abs(np.sum(p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]))
        return 1.0 - area / (math.pi * self.radius ** 2)

    @cached_property
    def _segments(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        p = self.polygon
        d = np.roll(p, -1, axis=0) - p
        return p[:, 0].copy(), p[:, 1].copy(), d[:, 0].copy(), d[:, 1].copy(), (d * d).sum(axis=1)

    def clearance(self, x, y) -> float:
        """Signed distance from (x, y) to the wall: positive inside, negative outside."""
        if not self.deformed:
            return self.radius - math.hypot(x, y)
        px, py, dx, dy, dd = self._segments
        wx, wy = x - px, y - py
        s = np.clip((wx * dx + wy * dy) / dd, 0.0, 1.0)
        dist = math.sqrt(float(np.min((wx - s * dx) ** 2 + (wy - s * dy) ** 2)))
        inside = math.hypot(x, y) <= self.radius * (1.0 - self.push * 0.5 * (1.0 + math.cos(math.atan2(y, x) - self.upstream)))
        return dist if inside else -dist
