"""OMPL validity for the known map: a per-state checker and an exact straight-segment validator.

Why a motion validator of our own: OMPL's default (DiscreteMotionValidator) calls the Python state
checker at every interpolation step of every motion, so a plan costs thousands of Python calls and
still only checks points. ``SegmentMotionValidator`` makes one call per motion and tests the whole
segment analytically (``geometry.segment_valid``), which is both faster and exact. States are read
with ``state[0]``/``state[1]`` (RealVectorStateSpace) or ``getX``/``getY`` (Dubins/SE2).
"""
from __future__ import annotations

from typing import Callable

from ompl import base as ob

from .geometry import point_valid, segment_valid
from .known_map import KnownMap


def r2_state_checker(kmap: KnownMap, margin: float) -> Callable[[object], bool]:
    """Validity of an R^2 state: clearance >= margin (closure over locals: no attribute lookups)."""
    R, sq, ci = kmap.net_radius, kmap.squares, kmap.circles

    def is_valid(state) -> bool:
        return point_valid(state[0], state[1], R, margin, sq, ci)
    return is_valid


def se2_state_checker(kmap: KnownMap, margin: float) -> Callable[[object], bool]:
    """Validity of an SE(2) state (Dubins mode): position only, heading is free."""
    R, sq, ci = kmap.net_radius, kmap.squares, kmap.circles

    def is_valid(state) -> bool:
        return point_valid(state.getX(), state.getY(), R, margin, sq, ci)
    return is_valid


class SegmentMotionValidator(ob.MotionValidator):
    """Straight motion a -> b is valid when the whole segment keeps ``margin`` clearance.

    Counts its calls: for RRT every iteration makes exactly one motion check, so ``checks`` is the
    number of samples drawn.
    """

    def __init__(self, si: ob.SpaceInformation, kmap: KnownMap, margin: float) -> None:
        super().__init__(si)
        self._args = (kmap.net_radius, margin, kmap.squares, kmap.circles)
        self.checks = 0

    def checkMotion(self, a, b) -> bool:  # noqa: N802 - OMPL's name
        self.checks += 1
        R, m, sq, ci = self._args
        return segment_valid(a[0], a[1], b[0], b[1], R, m, sq, ci)
