"""The observation layout: one definition shared by the env, the trainer, the evaluator and the nodes.

Vector (float32), in order:
  [0, n_beams)   sonar ranges / max_range, clipped to [0, 1]; no return (inf) and invalid (NaN) -> 1
  n_beams        distance to the current waypoint / waypoint_scale, clipped to [0, 1]
  n_beams + 1    heading error to the current waypoint / pi, in [-1, 1) (body frame, left positive)

Body frame as in the study: the policy sees the world relative to the vehicle, which is what made
its agent converge (the world-frame attempt did not in 38 hours). A policy file records this layout
(``to_dict``) and is refused when it does not match (``check_compatible``).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

LAYOUT_NAME = "cage-obs-v1"


@dataclass(frozen=True)
class ObservationLayout:
    n_beams: int = 72
    max_range: float = 20.0
    waypoint_scale: float = 20.0

    @property
    def size(self) -> int:
        return self.n_beams + 2

    def names(self) -> list[str]:
        return [f"range_{i}" for i in range(self.n_beams)] + ["waypoint_distance", "heading_error"]

    def build(self, ranges: np.ndarray, waypoint_distance, heading_error) -> np.ndarray:
        """Observation(s) from raw ranges (..., n_beams) in metres and the waypoint in polar form."""
        r = np.asarray(ranges, dtype=np.float64)
        if r.shape[-1] != self.n_beams:
            raise ValueError(f"expected {self.n_beams} ranges, got {r.shape[-1]}")
        norm = np.where(np.isfinite(r), r / self.max_range, 1.0)
        norm = np.clip(norm, 0.0, 1.0)
        d = np.clip(np.asarray(waypoint_distance, dtype=np.float64) / self.waypoint_scale, 0.0, 1.0)
        e = ((np.asarray(heading_error, dtype=np.float64) + math.pi) % (2 * math.pi) - math.pi) / math.pi
        return np.concatenate([norm, d[..., None], e[..., None]], axis=-1).astype(np.float32)

    def ranges_from(self, obs: np.ndarray) -> np.ndarray:
        """Ranges in metres back from observation(s) (max range where nothing was seen)."""
        return np.asarray(obs)[..., : self.n_beams] * self.max_range

    def waypoint_from(self, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(distance in m, heading error in rad) back from observation(s)."""
        o = np.asarray(obs)
        return o[..., self.n_beams] * self.waypoint_scale, o[..., self.n_beams + 1] * math.pi

    def to_dict(self) -> dict:
        return {"name": LAYOUT_NAME, **asdict(self)}

    @classmethod
    def from_dict(cls, d: dict) -> "ObservationLayout":
        if d.get("name") != LAYOUT_NAME:
            raise ValueError(f"observation layout {d.get('name')!r} is not {LAYOUT_NAME!r}")
        return cls(int(d["n_beams"]), float(d["max_range"]), float(d["waypoint_scale"]))

    def check_compatible(self, d: dict) -> None:
        """Raise ValueError naming every field in which a stored layout differs from this one."""
        other = {"name": d.get("name")} | {k: d.get(k) for k in asdict(self)}
        mine = self.to_dict()
        diffs = [f"{k}: file has {other[k]!r}, this build uses {mine[k]!r}" for k in mine if other[k] != mine[k]]
        if diffs:
            raise ValueError("observation layout mismatch: " + "; ".join(diffs))
