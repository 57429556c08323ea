"""The known map packed for the collision kernels: net radius plus obstacle rows.

Built from a ``cage_sim.world.World`` (only its ``known`` obstacles: the global planner must not
see what only the sonar sees). Packing happens once per map, never per check.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cage_sim.world import Obstacle, World


@dataclass(frozen=True)
class KnownMap:
    """Net radius, squares (cx, cy, half_side) and circles (cx, cy, radius), float64 C arrays."""

    net_radius: float
    squares: np.ndarray
    circles: np.ndarray

    @classmethod
    def from_world(cls, world: World) -> "KnownMap":
        return cls.from_obstacles(world.net_radius, world.known)

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


def _rows(rows: list) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(rows, dtype=np.float64).reshape(-1, 3))


def as_known_map(world_or_map: "World | KnownMap") -> KnownMap:
    if isinstance(world_or_map, KnownMap):
        return world_or_map
    if isinstance(world_or_map, World):
        return KnownMap.from_world(world_or_map)
    raise TypeError(f"expected a cage_sim World or a KnownMap, got {type(world_or_map).__name__}")
