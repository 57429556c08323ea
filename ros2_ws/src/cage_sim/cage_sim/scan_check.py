"""Is this LaserScan the one the policy was trained on? (pure; no ROS import)

A scan is only usable when every beam means what the observation layout says it means: the right
frame, the right number of beams, beam 0 at the right angle and the right spacing. A scan rotated by
180 deg, or one from another sensor profile, has valid-looking ranges and would steer the vehicle into
what it sees behind it, so it is refused, not "mostly used". Ranges may be missing (NaN, negative:
read as "no return") up to a fraction; ``inf`` is REP 117's "nothing within range" and is valid.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np


@dataclass(frozen=True)
class ScanSpec:
    """What a usable scan looks like (from the sonar model every node shares)."""

    n_beams: int
    angle_min: float
    angle_increment: float
    frame_id: str
    max_invalid_fraction: float = 0.25
    angle_tolerance: float = 1e-4  # rad: float32 on the wire, not a different sensor
    rotating: bool = False         # a mechanical head: published from its oldest beam, so angle_min is
    #                                any beam's angle (``sonar.scan_from_laserscan`` checks the sector)

    @classmethod
    def from_sonar(cls, sonar, frame_id: str, max_invalid_fraction: float = 0.25) -> "ScanSpec":
        return cls(int(sonar.n_beams), float(sonar.angle_min), float(sonar.angle_increment), frame_id,
                   float(max_invalid_fraction), rotating=bool(getattr(sonar, "mechanical", False)))


def scan_problem(spec: ScanSpec, frame_id: str, angle_min: float, angle_increment: float,
                 ranges: Sequence[float] | np.ndarray) -> str | None:
    """One line saying why the scan cannot be used, or None if it can."""
    if spec.frame_id and frame_id != spec.frame_id:
        return f"scan in frame {frame_id[:40]!r}, expected {spec.frame_id!r}"
    if not math.isfinite(angle_min) or (not spec.rotating and abs(wrap(angle_min - spec.angle_min)) > spec.angle_tolerance):
        return f"scan angle_min {angle_min:.4g} rad, expected {spec.angle_min:.4g} (a rotated scan)"
    if not (math.isfinite(angle_increment) and abs(angle_increment - spec.angle_increment) <= spec.angle_tolerance):
        return f"scan angle_increment {angle_increment:.4g} rad, expected {spec.angle_increment:.4g}"
    r = np.asarray(ranges, dtype=np.float64)
    if r.shape != (spec.n_beams,):
        return f"scan has {r.size} ranges, expected {spec.n_beams}"
    invalid = np.isnan(r) | (r < 0)
    if invalid.mean() > spec.max_invalid_fraction:
        return f"{int(invalid.sum())} of {r.size} ranges are invalid (NaN or negative)"
    return None


def wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi
