"""The sea-cage world: a net (circle, or deformed by the current), known and unknown obstacles, moving
obstacles, fish schools and a current field.

One definition of the geometry that the simulator, the sonar, the planner's map and the gym
environments all share. Pure NumPy/`math`, no ROS.

Conventions: map frame ENU, metres, net centred on the origin. A square is axis-aligned and its
``size`` is the side length; a circle's ``size`` is its radius. A moving obstacle oscillates about its
centre: ``centre(t) = (x, y) + (ax, ay) * sin(2*pi*t/period)`` (a fish school drifting to and fro).
Fish schools that react to the vehicle are stateful (fish.py): a ``World`` describes them, and the
episode's ``FishState`` positions enter a snapshot ``world.with_fish(state.circles())`` that the sonar and
the collision test use. The net the sonar and collision see is ``world.net`` (net.py); the planner's
``known_map()`` keeps the nominal circle.
"""
from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field, replace
from typing import Iterable, Literal, Sequence

import numpy as np

from .current import CurrentField, CurrentMode
from .fish import FishSchool
from .net import NetShape

Shape = Literal["square", "circle"]
SHAPES: tuple[str, ...] = ("square", "circle")


@dataclass(frozen=True)
class Obstacle:
    """A square (side ``size``) or circle (radius ``size``), optionally oscillating in time."""

    shape: Shape
    x: float
    y: float
    size: float
    ax: float = 0.0
    ay: float = 0.0
    period: float = 0.0

    def __post_init__(self) -> None:
        if self.shape not in SHAPES:
            raise ValueError(f"obstacle shape must be one of {SHAPES}, got {self.shape!r}")
        for name in ("x", "y", "ax", "ay", "period"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"obstacle {name} must be finite, got {getattr(self, name)!r}")
        if not (self.size > 0 and math.isfinite(self.size)):
            raise ValueError(f"obstacle size must be a positive number, got {self.size!r}")
        if (self.ax or self.ay) and not self.period > 0:
            raise ValueError("a moving obstacle needs a positive period")

    @property
    def moving(self) -> bool:
        return bool(self.ax or self.ay)

    @property
    def bound(self) -> float:
        """Radius of the circle around the centre that holds the obstacle (used for culling)."""
        return self.size * (math.sqrt(0.5) if self.shape == "square" else 1.0)

    def centre(self, t: float = 0.0) -> tuple[float, float]:
        if not self.moving:
            return self.x, self.y
        s = math.sin(2.0 * math.pi * t / self.period)
        return self.x + self.ax * s, self.y + self.ay * s

    def distance(self, px: float, py: float, t: float = 0.0) -> float:
        """Signed distance from a point to the obstacle's boundary (negative inside)."""
        cx, cy = self.centre(t)
        if self.shape == "circle":
            return math.hypot(px - cx, py - cy) - self.size
        h = 0.5 * self.size
        dx, dy = abs(px - cx) - h, abs(py - cy) - h
        outside = math.hypot(max(dx, 0.0), max(dy, 0.0))
        return outside + min(max(dx, dy), 0.0)

    def inflated(self, margin: float) -> "Obstacle":
        """The same obstacle grown by ``margin`` (a square keeps its shape: conservative corners)."""
        grow = 2.0 * margin if self.shape == "square" else margin
        return replace(self, size=self.size + grow)


@dataclass(frozen=True)
class ObstacleArrays:
    """Obstacle geometry at one instant as packed arrays, the form the sonar kernels take.

    squares: (N, 3) rows of (cx, cy, half_side); circles: (M, 3) rows of (cx, cy, radius).
    """

    squares: np.ndarray
    circles: np.ndarray


def obstacle_clearance(arrs: ObstacleArrays, x: float, y: float) -> float:
    """Signed distance from a point to the nearest packed obstacle (inf with none).

    Why two passes: NumPy over all rows finds the few obstacles within 1e-9 m of the nearest (one
    call per collision test instead of a Python call per obstacle), then those few are measured
    with the scalar formulas of ``Obstacle.distance`` (``math.hypot``; ``np.hypot`` can differ in
    the last bit), so the result is bit-identical to measuring every obstacle one at a time."""
    sq, ci = arrs.squares, arrs.circles
    if not len(sq) and not len(ci):
        return math.inf
    dx, dy = np.abs(x - sq[:, 0]) - sq[:, 2], np.abs(y - sq[:, 1]) - sq[:, 2]
    d_sq = np.hypot(np.maximum(dx, 0.0), np.maximum(dy, 0.0)) + np.minimum(np.maximum(dx, dy), 0.0)
    d_ci = np.hypot(x - ci[:, 0], y - ci[:, 1]) - ci[:, 2]
    near = min(d_sq.min(initial=math.inf), d_ci.min(initial=math.inf)) + 1e-9
    best = math.inf
    for cx, cy, h in sq[d_sq <= near].tolist():
        ex, ey = abs(x - cx) - h, abs(y - cy) - h
        best = min(best, math.hypot(max(ex, 0.0), max(ey, 0.0)) + min(max(ex, ey), 0.0))
    for cx, cy, r in ci[d_ci <= near].tolist():
        best = min(best, math.hypot(x - cx, y - cy) - r)
    return best


def pack(obstacles: Iterable[Obstacle], t: float = 0.0) -> ObstacleArrays:
    sq, ci = [], []
    for ob in obstacles:
        cx, cy = ob.centre(t)
        if ob.shape == "square":
            sq.append((cx, cy, 0.5 * ob.size))
        else:
            ci.append((cx, cy, ob.size))
    return ObstacleArrays(np.asarray(sq, dtype=np.float64).reshape(-1, 3),
                          np.asarray(ci, dtype=np.float64).reshape(-1, 3))


@dataclass(frozen=True)
class World:
    """The cage: net circle, obstacles on the map (``known``), obstacles only the sonar sees
    (``unknown``), a uniform water current (m/s, map frame, inside the pen) and the collision safety
    radius; optionally slowly varying current modes (capped at ``current_cap``), a net deformation
    (``net_loss``: area fraction lost, None = from the current, net.py) and fish schools.
    ``fish``: (K, 3) circles of the schools at this instant (set by ``with_fish``)."""

    net_radius: float = 30.0
    known: tuple[Obstacle, ...] = ()
    unknown: tuple[Obstacle, ...] = ()
    current: tuple[float, float] = (0.0, 0.0)
    safety_radius: float = 0.5
    current_modes: tuple[CurrentMode, ...] = ()
    current_cap: float = math.inf
    net_loss: float | None = 0.0
    schools: tuple[FishSchool, ...] = ()
    fish: np.ndarray | None = field(default=None, compare=False, repr=False)
    _static: ObstacleArrays | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        if not (self.net_radius > 0 and math.isfinite(self.net_radius)):
            raise ValueError(f"net_radius must be a positive number, got {self.net_radius!r}")
        if not self.safety_radius >= 0:
            raise ValueError(f"safety_radius must be >= 0, got {self.safety_radius!r}")
        object.__setattr__(self, "known", tuple(self.known))
        object.__setattr__(self, "unknown", tuple(self.unknown))
        object.__setattr__(self, "current", (float(self.current[0]), float(self.current[1])))
        object.__setattr__(self, "current_modes", tuple(self.current_modes))
        object.__setattr__(self, "schools", tuple(self.schools))
        object.__setattr__(self, "_current_field", CurrentField(self.current, self.current_modes, self.current_cap))
        object.__setattr__(self, "_net", NetShape.from_current(self.net_radius, self.current, self.net_loss))
        fish = np.zeros((0, 3)) if self.fish is None else np.asarray(self.fish, dtype=np.float64).reshape(-1, 3)
        if self.fish is None and self.schools:
            fish = np.array([[s.x, s.y, s.radius] for s in self.schools], dtype=np.float64)
        object.__setattr__(self, "_fish", fish)
        object.__setattr__(self, "_static", None)
        if not any(ob.moving for ob in self.obstacles):
            object.__setattr__(self, "_static", self._with_fish(pack(self.obstacles)))

    def _with_fish(self, arrs: ObstacleArrays) -> ObstacleArrays:
        if not len(self._fish):
            return arrs
        return ObstacleArrays(arrs.squares, np.ascontiguousarray(np.concatenate([arrs.circles, self._fish])))

    @property
    def current_field(self) -> CurrentField:
        return self._current_field

    @property
    def net(self) -> NetShape:
        """The wall the sonar and the collision test see (the nominal circle unless deformed)."""
        return self._net

    @property
    def obstacles(self) -> tuple[Obstacle, ...]:
        """Everything the sonar can see: known and unknown obstacles (fish schools: ``fish_circles``)."""
        return self.known + self.unknown

    @property
    def fish_circles(self) -> np.ndarray:
        """(K, 3) circles of the fish schools as placed in this snapshot."""
        return self._fish

    @property
    def has_moving(self) -> bool:
        return self._static is None

    def with_fish(self, circles: np.ndarray) -> "World":
        """This world with the schools at ``circles`` ((K, 3) rows of cx, cy, radius): a snapshot."""
        new = copy.copy(self)   # shares the net polygon, the current field and the packed static obstacles
        fish = np.ascontiguousarray(circles, dtype=np.float64).reshape(-1, 3)
        object.__setattr__(new, "fish", fish)
        object.__setattr__(new, "_fish", fish)
        if self._static is not None:
            base = self._static if not len(self._fish) else \
                ObstacleArrays(self._static.squares, self._static.circles[: len(self._static.circles) - len(self._fish)])
            object.__setattr__(new, "_static", new._with_fish(base))
        return new

    def arrays(self, t: float = 0.0) -> ObstacleArrays:
        """All obstacles packed for the sonar at time ``t`` (cached when nothing moves)."""
        return self._static if self._static is not None else self._with_fish(pack(self.obstacles, t))

    def known_map(self) -> "World":
        """What the global planner may use: the nominal net circle and the known obstacles only."""
        return World(self.net_radius, self.known, (), self.current, self.safety_radius)

    def clearance(self, x: float, y: float, t: float = 0.0) -> float:
        """Distance from a point to the nearest boundary (net or obstacle); negative inside one."""
        best = self._net.clearance(x, y)
        return min(best, obstacle_clearance(self.arrays(t), x, y))

    def in_collision(self, x: float, y: float, t: float = 0.0) -> bool:
        """The study's collision test, with boundaries: closer than the safety radius to anything."""
        return self.clearance(x, y, t) < self.safety_radius

    def inside_net(self, x: float, y: float, margin: float = 0.0) -> bool:
        """Inside the wall the sonar sees (deformed or not), at least ``margin`` from it."""
        if not self._net.deformed:
            return math.hypot(x, y) <= self.net_radius - margin
        return self._net.clearance(x, y) >= margin


def segment_clearance(world: World, points: Sequence[Sequence[float]], resolution: float = 0.1,
                      t: float = 0.0) -> float:
    """Smallest clearance along a polyline sampled every ``resolution`` metres (used by tests and
    benchmarks to check a path against the world independently of any planner)."""
    pts = np.asarray(points, dtype=float)
    best = math.inf
    for a, b in zip(pts[:-1], pts[1:]):
        n = max(2, int(math.ceil(np.linalg.norm(b - a) / resolution)) + 1)
        for s in np.linspace(0.0, 1.0, n):
            p = a + s * (b - a)
            best = min(best, world.clearance(float(p[0]), float(p[1]), t))
    if len(pts) == 1:
        best = world.clearance(float(pts[0][0]), float(pts[0][1]), t)
    return best
