"""The observation layouts: one definition shared by the env, the trainer, the evaluator and the nodes.

Two layouts. ``cage-obs-v1`` (``ObservationLayout``, unchanged: the first shipped policy uses it) and
``cage-obs-v2`` (``ObservationLayoutV2``: sensor profile recorded, optional velocity over ground and
memory). ``layout_from_dict`` reads either from a policy's metadata. ``ObservationBuilder`` turns what
a vehicle has at a decision (scan, pose, time, velocity over ground, waypoint) into the vector; the
env, the vec env and policy_node all call it, so the memory is kept the same way everywhere.

v1 vector (float32), in order:
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

from .memory import ReturnMemory

LAYOUT_NAME = "cage-obs-v1"
LAYOUT_V2 = "cage-obs-v2"


@dataclass(frozen=True)
class ObservationLayout:
    n_beams: int = 72
    max_range: float = 20.0
    waypoint_scale: float = 20.0

    @property
    def size(self) -> int:
        return self.n_beams + 2

    def low(self) -> np.ndarray:
        lo = np.zeros(self.size, dtype=np.float32)
        lo[-1] = -1.0
        return lo

    def high(self) -> np.ndarray:
        return np.ones(self.size, dtype=np.float32)

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


@dataclass(frozen=True)
class ObservationLayoutV2:
    """``cage-obs-v2``: float32 vector, in order (parts switched off are absent):

      scan      n_beams   ranges of the profile's beams / max_range in [0, 1]; no return -> 1
      memory    memory_bins  nearest remembered return per 360 deg body sector / max_range; none -> 1
      velocity  2         velocity over ground, body frame (forward, left) / speed_scale, clipped to [-1, 1]
      waypoint  2         distance / waypoint_scale in [0, 1]; heading error / pi in [-1, 1)

    The waypoint is always last, as in v1, so ``waypoint_from`` reads both layouts alike. The sensor
    geometry (profile, beams, first angle, spacing) is recorded: a policy trained on one sonar is
    refused on another, by field name.
    """

    profile: str = "study"
    n_beams: int = 72
    angle_min: float = 0.0
    angle_increment: float = math.radians(5.0)
    max_range: float = 20.0
    waypoint_scale: float = 20.0
    scan: bool = True
    velocity: bool = False
    speed_scale: float = 2.0
    memory_bins: int = 0
    memory_horizon: float = 10.0

    def __post_init__(self) -> None:
        if self.n_beams < 1 or self.memory_bins < 0:
            raise ValueError(f"observation: n_beams must be >= 1 and memory_bins >= 0, got "
                             f"{self.n_beams!r}, {self.memory_bins!r}")
        if not (self.scan or self.memory_bins):
            raise ValueError("observation: needs the scan or a memory (scan=False and memory_bins=0)")
        for name in ("max_range", "waypoint_scale", "speed_scale", "memory_horizon"):
            if not getattr(self, name) > 0:
                raise ValueError(f"observation.{name}: must be > 0, got {getattr(self, name)!r}")

    @staticmethod
    def for_sonar(sonar, waypoint_scale: float = 20.0, velocity: bool = False, memory_bins: int = 0,
                  memory_horizon: float = 10.0, scan: bool = True, speed_scale: float = 2.0) -> "ObservationLayoutV2":
        """The layout for a ``SonarModel`` (profile and beam geometry copied from it)."""
        return ObservationLayoutV2(sonar.profile, int(sonar.n_beams), float(sonar.angle_min),
                                   float(sonar.angle_increment), float(sonar.max_range), waypoint_scale, scan,
                                   velocity, speed_scale, memory_bins, memory_horizon)

    @property
    def n_scan(self) -> int:
        return self.n_beams if self.scan else 0

    @property
    def size(self) -> int:
        return self.n_scan + self.memory_bins + (2 if self.velocity else 0) + 2

    @property
    def fov(self) -> float:
        return self.n_beams * self.angle_increment

    @property
    def angles(self) -> np.ndarray:
        """Body angles of what ``ranges_from`` returns: the beams, or the memory bins without a scan."""
        if self.scan:
            return self.angle_min + self.angle_increment * np.arange(self.n_beams)
        return self.memory_angles

    @property
    def memory_angles(self) -> np.ndarray:
        return np.arange(self.memory_bins) * (2 * math.pi / max(self.memory_bins, 1))

    def names(self) -> list[str]:
        out = [f"range_{i}" for i in range(self.n_scan)] + [f"memory_{i}" for i in range(self.memory_bins)]
        if self.velocity:
            out += ["velocity_forward", "velocity_left"]
        return out + ["waypoint_distance", "heading_error"]

    def low(self) -> np.ndarray:
        lo = np.zeros(self.size, dtype=np.float32)
        lo[-1] = -1.0
        if self.velocity:
            lo[-4:-2] = -1.0
        return lo

    def high(self) -> np.ndarray:
        return np.ones(self.size, dtype=np.float32)

    def _norm(self, r) -> np.ndarray:
        r = np.asarray(r, dtype=np.float64)
        return np.clip(np.where(np.isfinite(r), r / self.max_range, 1.0), 0.0, 1.0)

    def build(self, ranges, waypoint_distance, heading_error, velocity=None, memory=None) -> np.ndarray:
        """Observation(s) from raw ranges (..., n_beams) m, waypoint (m, rad), velocity over ground
        (..., 2) m/s body frame, memory histogram (..., memory_bins) m. Unused parts may be None."""
        d = np.clip(np.asarray(waypoint_distance, dtype=np.float64) / self.waypoint_scale, 0.0, 1.0)
        e = ((np.asarray(heading_error, dtype=np.float64) + math.pi) % (2 * math.pi) - math.pi) / math.pi
        parts = []
        if self.scan:
            r = np.asarray(ranges, dtype=np.float64)
            if r.shape[-1] != self.n_beams:
                raise ValueError(f"expected {self.n_beams} ranges, got {r.shape[-1]}")
            parts.append(self._norm(r))
        if self.memory_bins:
            m = np.asarray(memory, dtype=np.float64)
            if memory is None or m.shape[-1] != self.memory_bins:
                raise ValueError(f"expected a memory histogram of {self.memory_bins} bins")
            parts.append(self._norm(m))
        if self.velocity:
            if velocity is None:
                raise ValueError("this layout needs the velocity over ground (2 values, body frame)")
            parts.append(np.clip(np.asarray(velocity, dtype=np.float64) / self.speed_scale, -1.0, 1.0))
        parts += [d[..., None], e[..., None]]
        shape = np.broadcast_shapes(*[p.shape[:-1] for p in parts])
        return np.concatenate([np.broadcast_to(p, shape + p.shape[-1:]) for p in parts], axis=-1).astype(np.float32)

    def ranges_from(self, obs: np.ndarray) -> np.ndarray:
        """Ranges (m) of the scan part (the memory part when there is no scan), at ``angles``."""
        o = np.asarray(obs)
        if self.scan:
            return o[..., : self.n_beams] * self.max_range
        return self.memory_from(o)

    def memory_from(self, obs: np.ndarray) -> np.ndarray:
        o = np.asarray(obs)
        return o[..., self.n_scan: self.n_scan + self.memory_bins] * self.max_range

    def velocity_from(self, obs: np.ndarray) -> np.ndarray | None:
        """Velocity over ground (m/s, body frame), None when the layout has none (clipped values stay clipped)."""
        if not self.velocity:
            return None
        return np.asarray(obs)[..., -4:-2] * self.speed_scale

    def waypoint_from(self, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        o = np.asarray(obs)
        return o[..., -2] * self.waypoint_scale, o[..., -1] * math.pi

    def to_dict(self) -> dict:
        return {"name": LAYOUT_V2, **asdict(self)}

    @classmethod
    def from_dict(cls, d: dict) -> "ObservationLayoutV2":
        if d.get("name") != LAYOUT_V2:
            raise ValueError(f"observation layout {d.get('name')!r} is not {LAYOUT_V2!r}")
        kinds = {f: type(v) for f, v in asdict(cls()).items()}
        missing = [f for f in kinds if f not in d]
        if missing:
            raise ValueError(f"observation layout: missing field(s) {', '.join(missing)}")
        return cls(**{f: kinds[f](d[f]) for f in kinds})

    def check_compatible(self, d: dict) -> None:
        """Raise ValueError naming every field in which a stored layout differs from this one (a
        different sensor profile says ``profile: file has 'fls', this build uses 'study'``)."""
        mine = self.to_dict()
        other = {k: d.get(k) for k in mine}
        if d.get("name") == LAYOUT_NAME:        # a v1 file: compare what v1 records
            other = {**mine, "name": LAYOUT_NAME, "n_beams": d.get("n_beams"), "max_range": d.get("max_range"),
                     "waypoint_scale": d.get("waypoint_scale"), "profile": "study"}
        diffs = []
        for k in mine:
            a, b = other[k], mine[k]
            same = (isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool)
                    and math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12)) or a == b
            if not same:
                diffs.append(f"{k}: file has {a!r}, this build uses {b!r}")
        if diffs:
            raise ValueError("observation layout mismatch: " + "; ".join(diffs))


Layout = "ObservationLayout | ObservationLayoutV2"


def layout_from_dict(d: dict) -> "ObservationLayout | ObservationLayoutV2":
    """The layout a policy file records (v1 or v2), by its ``name``."""
    name = d.get("name")
    if name == LAYOUT_NAME:
        return ObservationLayout.from_dict(d)
    if name == LAYOUT_V2:
        return ObservationLayoutV2.from_dict(d)
    raise ValueError(f"observation layout name: {name!r} is neither {LAYOUT_NAME!r} nor {LAYOUT_V2!r}")


class ObservationBuilder:
    """Per-vehicle state between decisions (the memory) plus the layout: (scan, pose, time, velocity
    over ground, waypoint) -> observation. One per vehicle; ``reset()`` at a new mission.

    ``build(ranges, x, y, yaw, t, waypoint_distance, heading_error, v_ground=None, angles=None,
    stamps=None, origins=None, new=None)``: ``ranges`` the scan's ranges (m, inf = no return);
    ``angles`` their body angles (default: the layout's beams); ``stamps`` / ``origins`` / ``new``
    when each beam fired, from which pose, and which are new since the last call (defaults: all now,
    from this pose, all new: an electronic sonar). A ``cage_sim.sonar.Scan`` has exactly these fields:
    ``build_scan(scan, ...)`` passes them.
    """

    def __init__(self, layout: "ObservationLayout | ObservationLayoutV2"):
        self.layout = layout
        bins = getattr(layout, "memory_bins", 0)
        self.memory = ReturnMemory(bins, layout.memory_horizon) if bins else None
        self.last_t = -math.inf
        self.cone: float | None = None     # beams' half-width (rad) when clearing is on (``clear_with``)
        self._last_xy: tuple[float, float] | None = None

    def clear_with(self, half_width: float) -> None:
        """Mark remembered returns cleared as beams see past them and the vehicle passes through them
        (``ReturnMemory.clear_seen_past`` / ``clear_swept``), for readers of
        ``memory.histogram(..., include_cleared=False)``; beams ``half_width`` rad either side of
        their axis. Off by default: the policy's observation is the same either way, and nobody
        else pays for it."""
        if not half_width >= 0:
            raise ValueError(f"beam half-width must be >= 0 rad, got {half_width!r}")
        self.cone = float(half_width)

    def reset(self) -> None:
        self.last_t = -math.inf
        self._last_xy = None
        if self.memory is not None:
            self.memory.reset()

    def build(self, ranges, x: float, y: float, yaw: float, t: float, waypoint_distance: float,
              heading_error: float, v_ground=None, angles=None, stamps=None, origins=None, new=None) -> np.ndarray:
        lay = self.layout
        if isinstance(lay, ObservationLayout):
            return lay.build(ranges, waypoint_distance, heading_error)
        hist = None
        if t < self.last_t - 1e-9:     # time went back: a new mission or a restarted clock
            self.reset()
        self.last_t = t
        if self.memory is not None:
            r = np.asarray(ranges, dtype=float)
            n = r.shape[-1]
            ang = lay.angles if angles is None and lay.scan else angles
            if ang is None:
                raise ValueError("the memory needs the beams' body angles when the layout has no scan")
            st = np.full(n, float(t)) if stamps is None else np.asarray(stamps, dtype=float)
            org = np.tile([x, y, yaw], (n, 1)) if origins is None else np.asarray(origins, dtype=float)
            sel = np.ones(n, dtype=bool) if new is None else np.asarray(new, dtype=bool)
            if self.cone is not None:
                if self._last_xy is not None:
                    self.memory.clear_swept(self._last_xy, (x, y))
                self.memory.clear_seen_past(r[sel], np.asarray(ang)[sel], org[sel], self.cone, lay.max_range)
            self._last_xy = (float(x), float(y))
            self.memory.add(r[sel], np.asarray(ang)[sel], org[sel], st[sel])
            self.memory.prune(t)
            hist = self.memory.histogram(x, y, yaw)
        return lay.build(ranges if lay.scan else None, waypoint_distance, heading_error, v_ground, hist)

    def build_scan(self, scan, x: float, y: float, yaw: float, t: float, waypoint_distance: float,
                   heading_error: float, v_ground=None) -> np.ndarray:
        """``build`` from a ``cage_sim.sonar.Scan``."""
        return self.build(scan.ranges, x, y, yaw, t, waypoint_distance, heading_error, v_ground,
                          scan.angles, scan.stamps, scan.origins, scan.new)
