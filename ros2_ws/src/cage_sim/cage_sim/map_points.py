"""The known map as points the safety shield keeps clear of, beside the sonar's returns (and that
the route tracker's goal in sight looks across: ``segment_clearance``).

Why: the shield checks its manoeuvres against what the sonar has returned, and a sonar that sees a
bearing once per sweep (``scanning``: one 2 deg beam at a time, 4 s a turn) leaves faces of an
obstacle unseen while the vehicle rounds it. On the whole ``sea`` matrix 52 of the 56 collisions of
the shielded ``scanning`` policy were with a known obstacle (22) or the net (30): the vehicle turned
round the corner it had seen into a face it had not. The planner has those obstacles and the net on
its map (``cage_planner_msgs/CageMap``, the ``map`` topic); a local costmap's static layer (nav2)
gives its controller the same. The net is the nominal circle: the current only pushes the wall in
(``net.NetShape``: the downstream wall stays at the nominal radius), so the circle is never inside
the water the vehicle may use, and it is where the current carries the vehicle onto the wall.

Points every ``spacing`` m along each outline: a manoeuvre that keeps ``c`` m from the points keeps
at least ``sqrt(c^2 - (spacing/2)^2)`` from the outline (0.97 m for 1 m at 0.5 m). Pure NumPy.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .perception import to_body
from .world import Obstacle, World

SPACING = 0.5   # m between points along an outline
MAX_POINTS = 100_000   # a map that needs more is refused (a 30 m net is 377 points, a 2 m square 16)


def _square(ob: Obstacle, spacing: float) -> np.ndarray:
    """Points along an axis-aligned square's outline (side ``size``), corners included."""
    h = 0.5 * ob.size
    n = max(1, math.ceil(ob.size / spacing))
    s = np.linspace(-h, h, n + 1)[:-1]
    sides = [np.c_[s, np.full(n, -h)], np.c_[np.full(n, h), s], np.c_[-s, np.full(n, h)], np.c_[np.full(n, -h), -s]]
    return np.concatenate(sides) + (ob.x, ob.y)


def _circle(cx: float, cy: float, r: float, spacing: float) -> np.ndarray:
    n = max(8, math.ceil(2 * math.pi * r / spacing))
    th = np.arange(n) * (2 * math.pi / n)
    return np.c_[cx + r * np.cos(th), cy + r * np.sin(th)]


@dataclass(frozen=True)
class MapPoints:
    """Map-frame points on the known obstacles' outlines and on the nominal net circle."""

    points: np.ndarray   # (N, 2)

    @staticmethod
    def from_world(world: World, spacing: float = SPACING) -> "MapPoints":
        """The points of ``world``'s known map: its known obstacles where the map puts them (their
        nominal centres) and its nominal net circle, as ``cage_sim.ros_convert.world_to_map`` sends it."""
        if not (spacing > 0 and math.isfinite(spacing)):
            raise ValueError(f"map point spacing must be a positive number of m, got {spacing!r}")
        perimeter = 2 * math.pi * world.net_radius + sum(
            4 * ob.size if ob.shape == "square" else 2 * math.pi * ob.size for ob in world.known)
        if perimeter / spacing > MAX_POINTS:
            raise ValueError(f"map too large for the shield: {perimeter:.0f} m of outlines is more than "
                             f"{MAX_POINTS} points at {spacing:g} m (net_radius {world.net_radius:g} m)")
        parts = [_circle(0.0, 0.0, world.net_radius, spacing)]
        for ob in world.known:
            parts.append(_square(ob, spacing) if ob.shape == "square" else _circle(ob.x, ob.y, ob.size, spacing))
        return MapPoints(np.ascontiguousarray(np.concatenate(parts)))

    def __len__(self) -> int:
        return len(self.points)

    def segment_clearance(self, a, b) -> float:
        """Metres from the segment ``a`` -> ``b`` (map frame) to the nearest map point (inf with
        none): whether the straight way between two points keeps clear of the known map
        (``route.RouteTracker``'s goal in sight)."""
        if len(self.points) == 0:
            return math.inf
        a, b = np.asarray(a, dtype=np.float64)[:2], np.asarray(b, dtype=np.float64)[:2]
        ab, ap = b - a, self.points - a
        n2 = float(ab @ ab)
        s = np.clip(ap @ ab / n2, 0.0, 1.0) if n2 > 0 else np.zeros(len(ap))
        d = ap - s[:, None] * ab
        return float(np.sqrt((d * d).sum(axis=1).min()))

    def near(self, pose, radius: float) -> np.ndarray:
        """(K, 2) body-frame points (x forward, y left) within ``radius`` m of a vehicle at ``pose``
        (x, y, yaw, map frame): what a decision's check adds to the returns."""
        x, y, yaw = pose
        d = self.points - (x, y)
        return to_body(d[d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] < radius * radius], yaw)
