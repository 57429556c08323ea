"""The known map packed for the collision kernels: net radius plus obstacle rows.

Built from a ``cage_sim.world.World`` (only its ``known`` obstacles: the global planner must not
see what only the sonar sees). Packing happens once per map, never per check.

Net model: ``nominal`` keeps the surveyed circle. ``current`` adds the wall the world's mean current
is predicted to push in (``cage_sim.net``: 20-40 % volume loss at 0.13-0.5 m/s, the upstream wall up
to ~0.5 R inside the circle). Why: routes planned on the circle alone ran outside the real wall when
they skirted a known obstacle near the upstream side (5 % of the routes in the hardest sea cell),
and the reactive layer then met a wall the route said was open water. The pushed-in wall enters as
discs tangent to it from outside, so the collision kernels stay the same (circles); the model is
convex, so no disc reaches inside it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cage_sim.net import NetShape
from cage_sim.scenarios import MAX_CURRENT
from cage_sim.vehicle import VehicleParams
from cage_sim.world import Obstacle, World

NET_MODELS = ("nominal", "current")
WALL_DISC = 20.0    # m, radius of the discs standing for the pushed-in wall
WALL_STEP = 2.0     # m between tangent points where the wall is pushed in most (wider where less)
WALL_MIN_PUSH = 0.25  # m: where the wall is within this of the circle, the circle stands for it


@dataclass(frozen=True)
class KnownMap:
    """Net radius, squares (cx, cy, half_side) and circles (cx, cy, radius), float64 C arrays."""

    net_radius: float
    squares: np.ndarray
    circles: np.ndarray

    @classmethod
    def from_world(cls, world: World, net_model: str = "nominal") -> "KnownMap":
        """The planner's map of ``world``; ``net_model`` (``NET_MODELS``) says which net wall it plans on."""
        err = net_model_error(net_model, world.current if net_model == "current" else (0.0, 0.0))
        if err:
            raise ValueError(err)
        kmap = cls.from_obstacles(world.net_radius, world.known)
        if net_model == "current":
            discs = wall_discs(NetShape.from_current(world.net_radius, world.current))
            if discs:
                kmap = cls(kmap.net_radius, kmap.squares, _rows(kmap.circles.tolist() + discs))
        return kmap

    @classmethod
    def from_obstacles(cls, net_radius: float, obstacles: "tuple[Obstacle, ...] | list[Obstacle]") -> "KnownMap":
        if not (math.isfinite(net_radius) and net_radius > 0):
            raise ValueError(f"net_radius must be a positive number, got {net_radius!r}")
        squares, circles = [], []
        for i, ob in enumerate(obstacles):
            if not (math.isfinite(ob.x) and math.isfinite(ob.y)):  # Obstacle checks only its size
                raise ValueError(f"obstacles[{i}]: centre must be finite, got ({ob.x}, {ob.y})")
            if ob.moving:  # a known moving obstacle: the circle it can sweep (conservative)
                circles.append((ob.x, ob.y, ob.bound + math.hypot(ob.ax, ob.ay)))
            elif ob.shape == "square":
                squares.append((ob.x, ob.y, 0.5 * ob.size))
            else:
                circles.append((ob.x, ob.y, ob.size))
        return cls(float(net_radius), _rows(squares), _rows(circles))

    def world(self) -> World:
        """The same map as a World (for independent checks with ``World.clearance``)."""
        obs = [Obstacle("square", x, y, 2.0 * h) for x, y, h in self.squares]
        obs += [Obstacle("circle", x, y, r) for x, y, r in self.circles]
        return World(self.net_radius, tuple(obs))


def net_model_error(net_model: str, current) -> str | None:
    """Why (``net_model``, ``current``) cannot make a planner map, or None: the model must be one of
    ``NET_MODELS`` and ``current`` two finite numbers (m/s, map frame, inside the pen) no faster than
    the scenarios' ``MAX_CURRENT`` (one limit for the world and the planner: a current as fast as the
    vehicle, or nearly, is one it cannot work in)."""
    if net_model not in NET_MODELS:
        return f"net_model: expected one of {NET_MODELS}, got {net_model!r}"
    vals = None if isinstance(current, (str, bytes)) or not hasattr(current, "__len__") else list(current)
    if vals is None or len(vals) != 2 or not all(
            isinstance(v, (int, float, np.floating)) and not isinstance(v, bool) and math.isfinite(v) for v in vals):
        return f"current: expected [vx, vy], two finite numbers in m/s, got {current!r}"
    speed = math.hypot(*vals)
    if speed > MAX_CURRENT:
        return (f"current: {speed:.2f} m/s is not slower than the vehicle by enough (the scenarios' limit, "
                f"MAX_CURRENT: {MAX_CURRENT} m/s; the vehicle does {VehicleParams().speed:.2f} m/s through the water)")
    return None


def wall_discs(net: NetShape) -> list[tuple[float, float, float]]:
    """(cx, cy, radius) discs of radius ``WALL_DISC`` touching the deformed wall from outside every
    ``WALL_STEP`` m of the innermost wall (equal angles: ~4 m apart where the wall is near the circle)
    where it lies more than ``WALL_MIN_PUSH`` inside the nominal circle (none for the circle). A disc
    tangent to a convex wall lies outside it; between two tangent points s apart the free space
    bulges out by about s^2 / (8 radius): 2.5 cm at 2 m, 10 cm at 4 m."""
    if not net.deformed:
        return []
    n = max(8, int(math.ceil(2 * math.pi * net.min_radius / WALL_STEP)))
    discs = []
    for theta in np.arange(n) * (2 * math.pi / n):
        r = float(net.r(theta))
        if net.radius - r < WALL_MIN_PUSH:
            continue
        ix, iy = net.inward(float(theta), 1.0)            # 1 m inside along the inward normal
        px, py = r * math.cos(theta), r * math.sin(theta)
        nx, ny = px - ix, py - iy                          # unit outward normal
        discs.append((px + WALL_DISC * nx, py + WALL_DISC * ny, WALL_DISC))
    return discs


def _rows(rows: list) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(rows, dtype=np.float64).reshape(-1, 3))


def as_known_map(world_or_map: "World | KnownMap") -> KnownMap:
    if isinstance(world_or_map, KnownMap):
        return world_or_map
    if isinstance(world_or_map, World):
        return KnownMap.from_world(world_or_map)
    raise TypeError(f"expected a cage_sim World or a KnownMap, got {type(world_or_map).__name__}")
