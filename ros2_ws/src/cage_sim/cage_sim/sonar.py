"""The sonar: one model, four profiles (``study``, ``multibeam360``, ``fls``, ``scanning``), by name.

One model for the env, the simulator node and the tests. Beam ``i`` points at body angle
``angle_min + i * angle_increment``. A beam reports the distance to the nearest surface in its cone
(``beam_width`` > 0: the nearest echo anywhere within +-beam_width/2, as a real beam does) or on its
centre line (``beam_width`` = 0: the study's ideal ray); beyond ``max_range`` it reports ``inf``, as
`sensor_msgs/LaserScan` (REP 117) says for "no return". A beam that starts inside an obstacle or
outside the net reports 0.

Profiles (``PROFILES``; ``make_sonar(name, **overrides)``; facts from ../shared/REFERENCE.md):
  study         the study's 72 ideal rays over 360 deg, 5 deg apart, 20 m (bit-identical to before).
  multibeam360  72 beams over 360 deg, 5 deg apart, each 2 deg wide (a real head's 1-2 deg beams), 0.05 m
                noise, 2 % dropout. Until session 40 each beam was 5 deg wide (no gaps): the nearest echo
                anywhere in a 5 deg cone drawn on the beam's centre line made every obstacle look 2.5 deg
                wider on each side and cost most of the 0.5 m/s timeouts
                (docs/results/mb360_sea_timeouts_s39.md); ``beam_width_deg=5`` gives that sonar back.
  fls           forward-looking multibeam (Oculus M750d / Gemini 720 class: 120-130 deg, 1-2 deg beams,
                up to 30-40 Hz): 130 deg sector, 64 beams of 2.03 deg, 15 Hz, 0.05 m noise, 1 % dropout.
  scanning      mechanical head (Ping360 class: 2 deg beam, 0.9 deg steps, 3-38 s per sweep): 180 beams
                of 2 deg, one at a time, a full sweep in 4 s; the scan holds the latest sweep, so part
                of it is up to 4 s old (``Scan.stamps``; LaserScan ``time_increment``).
Clutter (false echoes from fish: a short random return in a beam with probability ``clutter`` per
scan) and dropout are options of every profile.

Stateful heads: ``sonar.head()`` gives the object the env and sim_node both call once per scan,
``reset(...)`` then ``update(world, x, y, yaw, t, rng) -> Scan``. For a mechanical head it remembers
which beam fired last and when, fires the beams due since the last call from poses interpolated
along the way, and returns the latest sweep with per-beam stamps and firing poses.

Speed: the kernels are compiled with numba and cull obstacles that cannot be within range once per
scan (not per beam). They are vectorised over beams and over a batch of vehicles, each vehicle in
its own world (worlds are packed as flat arrays plus offsets).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Sequence

import numpy as np

from .world import ObstacleArrays, World

# numba is imported, and every kernel compiled (cached on disk), at the first kernel call, not at
# import: a process that only needs the sonar's geometry (the policy node: beam angles, LaserScan
# fields) stays ~60 MB smaller. Each kernel's module global is rebound to its compiled dispatcher,
# so kernels calling kernels compile against dispatchers.
_KERNELS: list = []


def _njit(**options):
    def wrap(fn):
        _KERNELS.append((fn, options))

        def first_call(*args):
            _compile_kernels()
            return globals()[fn.__name__](*args)
        first_call.__name__, first_call.__wrapped__ = fn.__name__, fn
        return first_call
    return wrap


def _compile_kernels() -> None:
    import numba
    for fn, options in _KERNELS:
        if not hasattr(globals()[fn.__name__], "py_func"):
            globals()[fn.__name__] = numba.njit(**options)(fn)

PROFILE_NAMES = ("study", "multibeam360", "fls", "scanning")


class SonarConfigError(ValueError):
    """An invalid sonar setting; the message starts with the field (``sonar.<name>``)."""


@dataclass(frozen=True)
class SonarModel:
    """Geometry and error model of the sonar (REP 117 conventions for out-of-range beams).

    noise_std: Gaussian range noise (m) on returns. dropout: probability that a beam returns no echo
    (reported as ``inf``, the same as out of range). clutter: probability that a beam reports a false
    echo at a uniform range in [min_range, clutter_range] (fish), when nearer than the true one.
    beam_width: rad; 0 = ideal ray. rate: scans per second the sim node publishes (metadata here).
    sweep_time: s per full sweep of a mechanical head (0: all beams at once).
    """

    n_beams: int = 72
    angle_min: float = 0.0
    angle_increment: float = math.radians(5.0)
    max_range: float = 20.0
    min_range: float = 0.0
    noise_std: float = 0.0
    dropout: float = 0.0
    profile: str = "study"
    beam_width: float = 0.0
    clutter: float = 0.0
    clutter_range: float = 10.0
    rate: float = 1.0
    sweep_time: float = 0.0

    def __post_init__(self) -> None:
        def bad(name: str, msg: str) -> SonarConfigError:
            return SonarConfigError(f"sonar.{name}: {msg}, got {getattr(self, name)!r}")
        if not isinstance(self.n_beams, (int, np.integer)) or self.n_beams < 1:
            raise bad("n_beams", "must be an integer >= 1")
        for name in ("angle_min", "angle_increment", "max_range", "min_range", "noise_std", "dropout",
                     "beam_width", "clutter", "clutter_range", "rate", "sweep_time"):
            if not math.isfinite(getattr(self, name)):
                raise bad(name, "must be finite")
        if self.profile not in PROFILE_NAMES:
            raise bad("profile", f"must be one of {PROFILE_NAMES}")
        if not self.max_range > 0:
            raise bad("max_range", "must be > 0")
        if not 0 <= self.min_range < self.max_range:
            raise bad("min_range", "must be in [0, max_range)")
        if not 0.0 <= self.dropout < 1.0:
            raise bad("dropout", "must be in [0, 1)")
        if not 0.0 <= self.clutter < 1.0:
            raise bad("clutter", "must be in [0, 1)")
        if self.noise_std < 0:
            raise bad("noise_std", "must be >= 0")
        if not 0 <= self.beam_width <= math.radians(30.0):
            raise bad("beam_width", "must be in [0, 30 deg] (rad)")
        if not self.angle_increment > 0:
            raise bad("angle_increment", "must be > 0")
        if self.n_beams * self.angle_increment > 2 * math.pi + 1e-9:
            raise bad("n_beams", "times angle_increment must not exceed 360 deg")
        if not self.rate > 0:
            raise bad("rate", "must be > 0 (scans per second)")
        if self.sweep_time < 0:
            raise bad("sweep_time", "must be >= 0 (s per sweep; 0 = all beams at once)")
        if not self.clutter_range > self.min_range:
            raise bad("clutter_range", "must be > min_range")

    @cached_property
    def angles(self) -> np.ndarray:
        """Body-frame beam angles (rad), computed once per model."""
        return self.angle_min + self.angle_increment * np.arange(self.n_beams)

    @property
    def angle_max(self) -> float:
        return self.angle_min + self.angle_increment * (self.n_beams - 1)

    @property
    def fov(self) -> float:
        """Angular coverage (rad): n_beams * angle_increment (2 pi for the 360 deg profiles)."""
        return self.n_beams * self.angle_increment

    @property
    def time_increment(self) -> float:
        """Seconds between consecutive beams (LaserScan ``time_increment``): 0 unless mechanical."""
        return self.sweep_time / self.n_beams

    @property
    def mechanical(self) -> bool:
        return self.sweep_time > 0

    @property
    def _exact(self) -> bool:
        return self.beam_width == 0.0

    def to_dict(self) -> dict:
        """Settings in the units the YAML / ROS params use (degrees), for metadata and scenario files."""
        return {"profile": self.profile, "n_beams": int(self.n_beams),
                "angle_min_deg": math.degrees(self.angle_min), "fov_deg": math.degrees(self.fov),
                "beam_width_deg": math.degrees(self.beam_width), "max_range": self.max_range,
                "min_range": self.min_range, "noise_std": self.noise_std, "dropout": self.dropout,
                "clutter": self.clutter, "clutter_range": self.clutter_range, "rate_hz": self.rate,
                "sweep_time": self.sweep_time}

    def head(self) -> "SonarHead":
        """The per-vehicle state object the env and sim_node call once per scan."""
        return ScanningHead(self) if self.mechanical else SonarHead(self)

    def scan(self, world: World, x: float, y: float, yaw: float, t: float = 0.0,
             rng: np.random.Generator | None = None) -> np.ndarray:
        """One scan from pose (x, y, yaw) in ``world`` at time ``t``; shape (n_beams,). All beams at
        once (a mechanical head's timing is ``head()``'s business)."""
        arrs = world.arrays(t)
        out = np.empty(self.n_beams)
        poly = world.net.polygon
        if self._exact and not len(poly):
            _scan_one(x, y, yaw, self.angles, world.net_radius, arrs.squares, arrs.circles,
                      self.max_range, out)
        else:
            _scan_one_cone(x, y, yaw, self.angles, 0.5 * self.beam_width, world.net_radius, poly,
                           arrs.squares, arrs.circles, self.max_range, out)
        return self._corrupt(out, rng)

    def scan_batch(self, worlds: Sequence[World], poses: np.ndarray, t: np.ndarray | float = 0.0,
                   rng: np.random.Generator | None = None) -> np.ndarray:
        """Scans for B vehicles; vehicle b lives in ``worlds[b]`` (or all in ``worlds[0]`` when one
        world is given). ``poses`` is (B, 3) of (x, y, yaw); returns (B, n_beams)."""
        poses = np.ascontiguousarray(poses, dtype=np.float64).reshape(-1, 3)
        packed = PackedWorlds.build(worlds, t, len(poses))
        out = np.empty((len(poses), self.n_beams))
        if self._exact and not len(packed.polys):
            _scan_batch(poses, self.angles, packed.net_radius, packed.world_of, packed.squares,
                        packed.sq_offsets, packed.circles, packed.ci_offsets, self.max_range, out)
        else:
            _scan_batch_cone(poses, self.angles, 0.5 * self.beam_width, packed.net_radius, packed.world_of,
                             packed.polys, packed.poly_offsets, packed.squares, packed.sq_offsets,
                             packed.circles, packed.ci_offsets, self.max_range, out)
        return self._corrupt(out, rng)

    def cast(self, world: World, origins: np.ndarray, angles: np.ndarray, t: float = 0.0) -> np.ndarray:
        """One beam per row: body angle ``angles[k]`` from pose ``origins[k]`` (a mechanical head's beams,
        each fired from where the vehicle was then). No noise (see ``corrupt``)."""
        arrs = world.arrays(t)
        origins = np.ascontiguousarray(origins, dtype=np.float64).reshape(-1, 3)
        out = np.empty(len(origins))
        _cast_beams(origins, np.ascontiguousarray(angles, dtype=np.float64), 0.5 * self.beam_width,
                    world.net_radius, world.net.polygon, arrs.squares, arrs.circles, self.max_range, out)
        return out

    def corrupt(self, ranges: np.ndarray, rng: np.random.Generator | None) -> np.ndarray:
        """Noise, clutter and dropout (a copy; untouched when ``rng`` is None or all are off)."""
        return self._corrupt(np.array(ranges, dtype=np.float64), rng)

    @property
    def noisy(self) -> bool:
        """Whether ``corrupt`` changes anything (noise, clutter or dropout is on)."""
        return self.noise_std > 0.0 or self.dropout > 0.0 or self.clutter > 0.0

    def _corrupt(self, ranges: np.ndarray, rng: np.random.Generator | None) -> np.ndarray:
        if rng is None or not self.noisy:
            return ranges
        finite = np.isfinite(ranges)
        if self.noise_std > 0:
            noisy = ranges + rng.normal(0.0, self.noise_std, ranges.shape)
            ranges = np.where(finite, np.clip(noisy, self.min_range, None), ranges)
        if self.clutter > 0:
            fake = rng.uniform(self.min_range, self.clutter_range, ranges.shape)
            ranges = np.where(rng.random(ranges.shape) < self.clutter, np.minimum(ranges, fake), ranges)
        if self.dropout > 0:
            ranges = np.where(rng.random(ranges.shape) < self.dropout, np.inf, ranges)
        ranges[ranges > self.max_range] = np.inf
        return ranges


def _sector(n_beams: int, fov_deg: float) -> dict:
    inc = math.radians(fov_deg) / n_beams
    if fov_deg >= 360.0 - 1e-9:
        return {"angle_min": 0.0, "angle_increment": inc}
    return {"angle_min": -0.5 * math.radians(fov_deg) + 0.5 * inc, "angle_increment": inc}


# Defaults per profile in YAML/param units (degrees, Hz). ``beam_width_deg`` None = the beam spacing.
PROFILES: dict[str, dict[str, Any]] = {
    "study": {"n_beams": 72, "fov_deg": 360.0, "beam_width_deg": 0.0, "max_range": 20.0, "noise_std": 0.0,
              "dropout": 0.0, "clutter": 0.0, "rate_hz": 1.0, "sweep_time": 0.0},
    "multibeam360": {"n_beams": 72, "fov_deg": 360.0, "beam_width_deg": 2.0, "max_range": 20.0,
                     "noise_std": 0.05, "dropout": 0.02, "clutter": 0.0, "rate_hz": 10.0, "sweep_time": 0.0},
    "fls": {"n_beams": 64, "fov_deg": 130.0, "beam_width_deg": None, "max_range": 20.0, "noise_std": 0.05,
            "dropout": 0.01, "clutter": 0.0, "rate_hz": 15.0, "sweep_time": 0.0},
    "scanning": {"n_beams": 180, "fov_deg": 360.0, "beam_width_deg": 2.0, "max_range": 20.0, "noise_std": 0.05,
                 "dropout": 0.01, "clutter": 0.0, "rate_hz": 1.0, "sweep_time": 4.0},
}
_SETTING_KEYS = ("n_beams", "fov_deg", "beam_width_deg", "max_range", "min_range", "noise_std", "dropout",
                 "clutter", "clutter_range", "rate_hz", "sweep_time")


def make_sonar(profile: "str | dict | SonarModel" = "study", **overrides: Any) -> SonarModel:
    """The sonar of a profile by name, with settings overridden in YAML units (``fov_deg``,
    ``beam_width_deg``, ``rate_hz``, ...); a dict ``{"profile": ..., **settings}`` works too.
    Unknown names and bad values raise ``SonarConfigError`` naming the field."""
    if isinstance(profile, SonarModel):
        if overrides:
            return make_sonar(profile.to_dict() | overrides)
        return profile
    if isinstance(profile, dict):
        d = dict(profile)
        return make_sonar(d.pop("profile", "study"), **d, **overrides)
    if profile not in PROFILES:
        raise SonarConfigError(f"sonar.profile: must be one of {PROFILE_NAMES}, got {profile!r}")
    for k in overrides:
        if k not in _SETTING_KEYS and k != "angle_min_deg":
            raise SonarConfigError(f"sonar.{k}: unknown setting (allowed: profile, {', '.join(_SETTING_KEYS)})")
    cfg = PROFILES[profile] | overrides
    for k, v in cfg.items():
        if v is None:
            continue
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
            raise SonarConfigError(f"sonar.{k}: expected a number, got {v!r}")
    n = cfg["n_beams"]
    if isinstance(n, float) and n.is_integer():
        n = int(n)
    if not isinstance(n, (int, np.integer)) or n < 1:
        raise SonarConfigError(f"sonar.n_beams: must be an integer >= 1, got {cfg['n_beams']!r}")
    fov = float(cfg["fov_deg"])
    if not 0 < fov <= 360.0:
        raise SonarConfigError(f"sonar.fov_deg: must be in (0, 360], got {fov!r}")
    sector = _sector(int(n), fov)
    if "angle_min_deg" in cfg:
        sector["angle_min"] = math.radians(float(cfg["angle_min_deg"]))
    if profile == "study" and fov == 360.0 and n == 72:
        sector["angle_increment"] = math.radians(5.0)   # the exact float the shipped policy was trained with
    bw = cfg["beam_width_deg"]
    bw = math.degrees(sector["angle_increment"]) if bw is None else float(bw)
    return SonarModel(n_beams=int(n), max_range=float(cfg["max_range"]), min_range=float(cfg.get("min_range", 0.0)),
                      noise_std=float(cfg["noise_std"]), dropout=float(cfg["dropout"]), profile=profile,
                      beam_width=math.radians(bw), clutter=float(cfg["clutter"]),
                      clutter_range=float(cfg.get("clutter_range", 10.0)), rate=float(cfg["rate_hz"]),
                      sweep_time=float(cfg["sweep_time"]), **sector)


# --------------------------------------------------------------------------- heads (per-vehicle state)

@dataclass
class Scan:
    """One published scan: ranges (m) per beam at body ``angles``; ``stamps`` when each beam fired;
    ``origins`` (n, 3) the pose each beam fired from; ``new`` the beams fired since the last scan
    (a memory adds only those, from their own origins)."""

    ranges: np.ndarray
    angles: np.ndarray
    stamps: np.ndarray
    origins: np.ndarray
    new: np.ndarray

    def ages(self, t: float) -> np.ndarray:
        return t - self.stamps


def laserscan_fields(scan: Scan, sonar: SonarModel) -> dict:
    """The ``sensor_msgs/LaserScan`` fields for a scan (REP 117; pure: sim_node fills the message).

    A LaserScan's ``header.stamp`` is the first beam's time and beam i is ``i * time_increment`` later.
    A mechanical head's latest sweep is therefore published starting at its OLDEST beam: ``angle_min``
    is that beam's angle and the ranges run in firing order, so each beam's age is exact. An electronic
    sonar's scan is published as is (``time_increment`` 0). ``scan_from_laserscan`` undoes it."""
    n = sonar.n_beams
    first = int(np.argmin(scan.stamps)) if sonar.mechanical else 0
    order = (first + np.arange(n)) % n
    a0 = sonar.angle_min + first * sonar.angle_increment
    a0 = (a0 + math.pi) % (2 * math.pi) - math.pi if sonar.mechanical else a0
    return {"stamp": float(scan.stamps[first]), "angle_min": a0,
            "angle_max": a0 + (n - 1) * sonar.angle_increment, "angle_increment": sonar.angle_increment,
            "time_increment": sonar.time_increment, "scan_time": sonar.sweep_time or 1.0 / sonar.rate,
            "range_min": sonar.min_range, "range_max": sonar.max_range, "ranges": scan.ranges[order].copy()}


def beam_origins(times: np.ndarray, previous: tuple[float, float, float, float],
                 now: tuple[float, float, float, float]) -> np.ndarray:
    """(K, 3) poses (x, y, yaw) the vehicle had at beam ``times``, interpolated linearly between two
    known poses ``previous`` and ``now`` (each ``(t, x, y, yaw)``; yaw the short way round, times
    clipped to the interval). The scanning head fires its beams from these poses and ``policy_node``
    places the beams it receives with the same function, so a memory of map points built from a
    mechanical head's sweeps is the same in the graph as offline."""
    t0, x0, y0, yaw0 = previous
    t, x, y, yaw = now
    f = np.clip((np.asarray(times, dtype=np.float64) - t0) / max(t - t0, 1e-12), 0.0, 1.0)
    dyaw = (yaw - yaw0 + math.pi) % (2 * math.pi) - math.pi
    return np.stack([x0 + f * (x - x0), y0 + f * (y - y0), yaw0 + f * dyaw], axis=-1)


def scan_from_laserscan(ranges, angle_min: float, angle_increment: float, stamp: float, time_increment: float,
                        sonar: SonarModel, pose: tuple[float, float, float],
                        previous_stamp: float = -math.inf,
                        track: tuple[tuple[float, float, float, float], tuple[float, float, float, float]] | None = None
                        ) -> Scan:
    """A received LaserScan back as a ``Scan`` in the profile's beam order (what ``ObservationBuilder``
    and the layout expect). ``pose``: the vehicle's pose now, every beam's origin by default. ``new``:
    beams later than ``previous_stamp`` (the latest beam time of the previous call). ``track``: two
    known poses ``(t, x, y, yaw)``, the previous decision's and this one's; the new beams are then
    placed where the vehicle was when each fired (``beam_origins``), as a mechanical head fired them.
    Raises ValueError (one line) when the scan is not this profile's."""
    r = np.asarray(ranges, dtype=np.float64)
    n = sonar.n_beams
    if r.shape != (n,):
        raise ValueError(f"scan has {r.size} ranges, the {sonar.profile} profile has {n}")
    if not math.isclose(angle_increment, sonar.angle_increment, rel_tol=1e-4):
        raise ValueError(f"scan angle_increment {angle_increment:.6f} rad is not the {sonar.profile} "
                         f"profile's {sonar.angle_increment:.6f}")
    shift = int(round(((angle_min - sonar.angle_min) % (2 * math.pi)) / sonar.angle_increment)) % n \
        if sonar.fov >= 2 * math.pi - 1e-9 else int(round((angle_min - sonar.angle_min) / sonar.angle_increment))
    if not 0 <= shift < n:
        raise ValueError(f"scan angle_min {angle_min:.4f} rad is outside the {sonar.profile} profile's sector")
    idx = (shift + np.arange(n)) % n
    out_r, stamps = np.empty(n), np.empty(n)
    out_r[idx] = r
    stamps[idx] = stamp + np.arange(n) * time_increment
    origins, new = np.tile(np.asarray(pose, dtype=np.float64), (n, 1)), stamps > previous_stamp
    if track is not None and new.any():
        origins[new] = beam_origins(stamps[new], *track)
    return Scan(out_r, sonar.angles, stamps, origins, new)


class SonarHead:
    """An electronic sonar (all beams at once): stateless apart from the last scan."""

    def __init__(self, sonar: SonarModel):
        self.sonar = sonar
        self.last: Scan | None = None

    def reset(self, world: World, x: float, y: float, yaw: float, t: float = 0.0,
              rng: np.random.Generator | None = None) -> Scan:
        return self.update(world, x, y, yaw, t, rng)

    def update(self, world: World, x: float, y: float, yaw: float, t: float = 0.0,
               rng: np.random.Generator | None = None) -> Scan:
        n = self.sonar.n_beams
        r = self.sonar.scan(world, x, y, yaw, t, rng)
        self.last = Scan(r, self.sonar.angles, np.full(n, float(t)), np.tile([x, y, yaw], (n, 1)),
                         np.ones(n, dtype=bool))
        return self.last


class ScanningHead(SonarHead):
    """A mechanical head: beam ``k`` fires at ``t0 + (k + m * n_beams) * time_increment``. ``update``
    fires every beam due in (last call, t] from the pose interpolated between the two calls' poses.
    ``reset`` fills a whole sweep from the start pose, ending at ``t`` (the vehicle waited there)."""

    def __init__(self, sonar: SonarModel):
        super().__init__(sonar)
        self.ranges = np.full(sonar.n_beams, np.inf)
        self.stamps = np.full(sonar.n_beams, -np.inf)
        self.origins = np.zeros((sonar.n_beams, 3))
        self.next_index = 0          # absolute count of the next beam to fire
        self.t0 = 0.0
        self.prev = (0.0, 0.0, 0.0, 0.0)   # (t, x, y, yaw) of the last update

    def reset(self, world: World, x: float, y: float, yaw: float, t: float = 0.0,
              rng: np.random.Generator | None = None) -> Scan:
        s, n = self.sonar, self.sonar.n_beams
        self.t0 = t - (n - 1) * s.time_increment
        ks = np.arange(n)
        self.origins = np.tile([x, y, yaw], (n, 1))
        self.ranges = s.corrupt(s.cast(world, self.origins, s.angles, t), rng)
        self.stamps = self.t0 + ks * s.time_increment
        self.next_index = n
        self.prev = (t, x, y, yaw)
        self.last = Scan(self.ranges.copy(), s.angles, self.stamps.copy(), self.origins.copy(),
                         np.ones(n, dtype=bool))
        return self.last

    def update(self, world: World, x: float, y: float, yaw: float, t: float = 0.0,
               rng: np.random.Generator | None = None) -> Scan:
        s, n = self.sonar, self.sonar.n_beams
        t_prev = self.prev[0]
        if t < t_prev - 1e-9:          # time went back (a new mission, a restarted clock): start over
            return self.reset(world, x, y, yaw, t, rng)
        last_k = int(math.floor((t - self.t0) / s.time_increment + 1e-9))
        ks = np.arange(self.next_index, last_k + 1)
        new = np.zeros(n, dtype=bool)
        if len(ks):
            ks = ks[-n:]
            times = self.t0 + ks * s.time_increment
            org = beam_origins(times, self.prev, (t, x, y, yaw))
            idx = ks % n
            r = s.corrupt(s.cast(world, org, s.angles[idx], t), rng)
            self.ranges[idx], self.stamps[idx], self.origins[idx] = r, times, org
            new[idx] = True
            self.next_index = last_k + 1
        self.prev = (t, x, y, yaw)
        self.last = Scan(self.ranges.copy(), s.angles, self.stamps.copy(), self.origins.copy(), new)
        return self.last

    @property
    def last_beam(self) -> int:
        """Index of the beam fired last (where the head points now)."""
        return (self.next_index - 1) % self.sonar.n_beams


@dataclass(frozen=True)
class PackedWorlds:
    """Several worlds as flat arrays plus offsets, so one compiled loop scans them all."""

    net_radius: np.ndarray
    world_of: np.ndarray
    squares: np.ndarray
    sq_offsets: np.ndarray
    circles: np.ndarray
    ci_offsets: np.ndarray
    polys: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    poly_offsets: np.ndarray = field(default_factory=lambda: np.zeros(1, dtype=np.int64))

    @staticmethod
    def build(worlds: Sequence[World], t: np.ndarray | float, n_vehicles: int) -> "PackedWorlds":
        worlds = list(worlds)
        times = np.broadcast_to(np.asarray(t, dtype=float), (len(worlds),)) if len(worlds) > 1 \
            else np.asarray([np.asarray(t, dtype=float).reshape(-1)[0]])
        arrs: list[ObstacleArrays] = [w.arrays(float(tt)) for w, tt in zip(worlds, times)]
        if len(worlds) == 1:
            world_of = np.zeros(n_vehicles, dtype=np.int64)
        elif len(worlds) == n_vehicles:
            world_of = np.arange(n_vehicles, dtype=np.int64)
        else:
            raise ValueError("give one world, or one world per vehicle")
        return PackedWorlds(
            net_radius=np.array([w.net_radius for w in worlds], dtype=np.float64),
            world_of=world_of,
            squares=np.concatenate([a.squares for a in arrs]).reshape(-1, 3),
            sq_offsets=np.cumsum([0] + [len(a.squares) for a in arrs]).astype(np.int64),
            circles=np.concatenate([a.circles for a in arrs]).reshape(-1, 3),
            ci_offsets=np.cumsum([0] + [len(a.circles) for a in arrs]).astype(np.int64),
            polys=np.concatenate([w.net.polygon for w in worlds]).reshape(-1, 2),
            poly_offsets=np.cumsum([0] + [len(w.net.polygon) for w in worlds]).astype(np.int64),
        )


@_njit(cache=True, fastmath=False)
def _ray_net(px, py, dx, dy, r):
    b = px * dx + py * dy
    c = px * px + py * py - r * r
    if c >= 0.0:
        return 0.0
    return -b + math.sqrt(b * b - c)


@_njit(cache=True, fastmath=False)
def _ray_circle(px, py, dx, dy, cx, cy, r):
    ox, oy = px - cx, py - cy
    c = ox * ox + oy * oy - r * r
    if c <= 0.0:
        return 0.0
    b = ox * dx + oy * dy
    if b >= 0.0:
        return math.inf
    disc = b * b - c
    if disc < 0.0:
        return math.inf
    return -b - math.sqrt(disc)


@_njit(cache=True, fastmath=False)
def _ray_square(px, py, dx, dy, cx, cy, h):
    tmin, tmax = -math.inf, math.inf
    lo, hi, p, d = cx - h, cx + h, px, dx
    for axis in range(2):
        if axis == 1:
            lo, hi, p, d = cy - h, cy + h, py, dy
        if d == 0.0:
            if p < lo or p > hi:
                return math.inf
        else:
            t1, t2 = (lo - p) / d, (hi - p) / d
            if t1 > t2:
                t1, t2 = t2, t1
            tmin, tmax = max(tmin, t1), min(tmax, t2)
    if tmax < tmin or tmax < 0.0:
        return math.inf
    return max(tmin, 0.0)


@_njit(cache=True, fastmath=False)
def _scan_into(px, py, yaw, angles, net_r, squares, s0, s1, circles, c0, c1, max_range, out, keep):
    # Cull once per scan: an obstacle whose nearest point is beyond range cannot be hit by any beam.
    nk = 0
    for k in range(s0, s1):
        cx, cy, h = squares[k, 0], squares[k, 1], squares[k, 2]
        if math.hypot(cx - px, cy - py) - 1.4142135623730951 * h <= max_range:
            keep[nk] = k
            nk += 1
    nc = 0
    for k in range(c0, c1):
        cx, cy, r = circles[k, 0], circles[k, 1], circles[k, 2]
        if math.hypot(cx - px, cy - py) - r <= max_range:
            keep[nk + nc] = k
            nc += 1
    for i in range(angles.shape[0]):
        a = yaw + angles[i]
        dx, dy = math.cos(a), math.sin(a)
        best = _ray_net(px, py, dx, dy, net_r)
        for j in range(nk):
            k = keep[j]
            t = _ray_square(px, py, dx, dy, squares[k, 0], squares[k, 1], squares[k, 2])
            if t < best:
                best = t
        for j in range(nc):
            k = keep[nk + j]
            t = _ray_circle(px, py, dx, dy, circles[k, 0], circles[k, 1], circles[k, 2])
            if t < best:
                best = t
        out[i] = best if best <= max_range else math.inf


@_njit(cache=True)
def _scan_one(px, py, yaw, angles, net_r, squares, circles, max_range, out):
    keep = np.empty(squares.shape[0] + circles.shape[0], dtype=np.int64)
    _scan_into(px, py, yaw, angles, net_r, squares, 0, squares.shape[0], circles, 0,
               circles.shape[0], max_range, out, keep)


@_njit(cache=True)
def _scan_batch(poses, angles, net_r, world_of, squares, sq_off, circles, ci_off, max_range, out):
    keep = np.empty(squares.shape[0] + circles.shape[0], dtype=np.int64)
    for b in range(poses.shape[0]):
        w = world_of[b]
        _scan_into(poses[b, 0], poses[b, 1], poses[b, 2], angles, net_r[w], squares, sq_off[w],
                   sq_off[w + 1], circles, ci_off[w], ci_off[w + 1], max_range, out[b], keep)


# --------------------------------------------------------------------------- beams with width / deformed net

@_njit(cache=True, fastmath=False)
def _wrap(a):
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@_njit(cache=True, fastmath=False)
def _ray_poly(px, py, dx, dy, poly, p0, p1, max_range, r_in, r_out):
    """Ray from inside the deformed net to its wall; 0 when starting outside, inf beyond ``max_range``.

    The wall is ``NetShape.polygon``: vertex k at map angle k * 2pi/n, star-shaped about the origin and
    between the circles of radius min|v| and max|v|. So only the stretch of the ray between leaving
    the inner circle and leaving the outer one (or max range) can meet it, and along a line the angle
    seen from the origin is monotonic: only the edges in that angular span are tested (a few, not n).
    ``r_in`` / ``r_out``: the smallest / largest vertex radius (``_radii``, once per scan).
    """
    n = p1 - p0
    step = 2.0 * math.pi / n
    rp = math.hypot(px, py)
    if rp >= r_out:
        return 0.0
    if rp > r_in:   # between the circles: inside iff on the origin's side of the chord at its angle
        k = int(math.floor((math.atan2(py, px) % (2.0 * math.pi)) / step)) % n
        ax, ay = poly[p0 + k, 0], poly[p0 + k, 1]
        j = p0 + (k + 1) % n
        bx, by = poly[j, 0], poly[j, 1]
        if (bx - ax) * (py - ay) - (by - ay) * (px - ax) < 0.0:
            return 0.0
    b = px * dx + py * dy
    t_in = 0.0 if rp >= r_in else -b + math.sqrt(max(b * b - (rp * rp - r_in * r_in), 0.0))
    if t_in > max_range:
        return math.inf
    t_end = min(-b + math.sqrt(max(b * b - (rp * rp - r_out * r_out), 0.0)), max_range)
    x0, y0 = px + t_in * dx, py + t_in * dy
    x1, y1 = px + t_end * dx, py + t_end * dy
    k0 = int(math.floor((math.atan2(y0, x0) % (2.0 * math.pi)) / step)) % n
    k1 = int(math.floor((math.atan2(y1, x1) % (2.0 * math.pi)) / step)) % n
    ccw = px * dy - py * dx >= 0.0
    best = math.inf
    k = k0
    for _ in range(n):
        ax, ay = poly[p0 + k, 0], poly[p0 + k, 1]
        j = p0 + (k + 1) % n
        ex, ey = poly[j, 0] - ax, poly[j, 1] - ay
        den = dx * ey - dy * ex
        if den != 0.0:
            wx, wy = ax - px, ay - py
            t = (wx * ey - wy * ex) / den
            u = (wx * dy - wy * dx) / den
            if t >= 0.0 and -1e-12 <= u <= 1.0 + 1e-12 and t < best:
                best = t
        if k == k1:
            break
        k = (k + 1) % n if ccw else (k - 1) % n
    return best if best <= max_range else math.inf


@_njit(cache=True, fastmath=False)
def _radii(poly, p0, p1):
    r_in, r_out = math.inf, 0.0
    for k in range(p0, p1):
        r = math.hypot(poly[k, 0], poly[k, 1])
        r_in = min(r_in, r)
        r_out = max(r_out, r)
    return r_in, r_out


@_njit(cache=True, fastmath=False)
def _net_cone(px, py, a, hw, net_r, poly, p0, p1, max_range, r_in, r_out):
    """Nearest net echo within +-hw of direction a. Round net: exact (the nearest wall point lies
    toward the outward direction, else on the cone edge nearest it). Deformed net: rays 1 deg apart."""
    if p1 > p0:
        n_sub = 1 if hw == 0.0 else 2 + int(2.0 * hw / 0.017453292519943295)
        best = math.inf
        for q in range(n_sub):
            b = a if n_sub == 1 else a - hw + 2.0 * hw * q / (n_sub - 1)
            t = _ray_poly(px, py, math.cos(b), math.sin(b), poly, p0, p1, max_range, r_in, r_out)
            if t < best:
                best = t
        return best
    rp = math.hypot(px, py)
    if rp >= net_r:
        return 0.0
    if hw > 0.0 and (rp == 0.0 or abs(_wrap(math.atan2(py, px) - a)) <= hw):
        return net_r - rp
    if hw == 0.0:
        return _ray_net(px, py, math.cos(a), math.sin(a), net_r)
    t1 = _ray_net(px, py, math.cos(a - hw), math.sin(a - hw), net_r)
    t2 = _ray_net(px, py, math.cos(a + hw), math.sin(a + hw), net_r)
    return min(t1, t2)


@_njit(cache=True, fastmath=False)
def _circle_cone(px, py, a, hw, cx, cy, r):
    """Nearest point of a circle within the cone (exact: convex shape, so it is the closest point when
    that lies in the cone, else on one of the cone's edge rays)."""
    ox, oy = cx - px, cy - py
    d = math.hypot(ox, oy)
    if d <= r:
        return 0.0
    if abs(_wrap(math.atan2(oy, ox) - a)) <= hw:
        return d - r
    if hw == 0.0:
        return _ray_circle(px, py, math.cos(a), math.sin(a), cx, cy, r)
    t1 = _ray_circle(px, py, math.cos(a - hw), math.sin(a - hw), cx, cy, r)
    t2 = _ray_circle(px, py, math.cos(a + hw), math.sin(a + hw), cx, cy, r)
    return min(t1, t2)


@_njit(cache=True, fastmath=False)
def _square_cone(px, py, a, hw, cx, cy, h):
    qx = min(max(px, cx - h), cx + h)
    qy = min(max(py, cy - h), cy + h)
    ox, oy = qx - px, qy - py
    d = math.hypot(ox, oy)
    if d == 0.0:
        return 0.0
    if abs(_wrap(math.atan2(oy, ox) - a)) <= hw:
        return d
    if hw == 0.0:
        return _ray_square(px, py, math.cos(a), math.sin(a), cx, cy, h)
    t1 = _ray_square(px, py, math.cos(a - hw), math.sin(a - hw), cx, cy, h)
    t2 = _ray_square(px, py, math.cos(a + hw), math.sin(a + hw), cx, cy, h)
    return min(t1, t2)


@_njit(cache=True, fastmath=False)
def _cone_into(px, py, yaw, angles, hw, net_r, poly, p0, p1, squares, s0, s1, circles, c0, c1,
               max_range, out, keep):
    # Cull once per scan by range, and note each kept obstacle's bearing and angular half-size, so a
    # beam only tests the obstacles its cone can overlap.
    r_in, r_out = _radii(poly, p0, p1) if p1 > p0 else (net_r, net_r)
    n_all = (s1 - s0) + (c1 - c0)
    bear = np.empty(n_all)
    half = np.empty(n_all)
    nk = 0
    for k in range(s0, s1):
        d = math.hypot(squares[k, 0] - px, squares[k, 1] - py)
        b = 1.4142135623730951 * squares[k, 2]
        if d - b <= max_range:
            keep[nk] = k
            bear[nk] = math.atan2(squares[k, 1] - py, squares[k, 0] - px) - yaw
            half[nk] = math.pi if d <= b else math.asin(b / d)
            nk += 1
    nc = 0
    for k in range(c0, c1):
        d = math.hypot(circles[k, 0] - px, circles[k, 1] - py)
        b = circles[k, 2]
        if d - b <= max_range:
            keep[nk + nc] = k
            bear[nk + nc] = math.atan2(circles[k, 1] - py, circles[k, 0] - px) - yaw
            half[nk + nc] = math.pi if d <= b else math.asin(b / d)
            nc += 1
    for i in range(angles.shape[0]):
        a = yaw + angles[i]
        best = _net_cone(px, py, a, hw, net_r, poly, p0, p1, max_range, r_in, r_out)
        for j in range(nk):
            if abs(_wrap(angles[i] - bear[j])) > hw + half[j] + 1e-9:
                continue
            k = keep[j]
            t = _square_cone(px, py, a, hw, squares[k, 0], squares[k, 1], squares[k, 2])
            if t < best:
                best = t
        for j in range(nc):
            if abs(_wrap(angles[i] - bear[nk + j])) > hw + half[nk + j] + 1e-9:
                continue
            k = keep[nk + j]
            t = _circle_cone(px, py, a, hw, circles[k, 0], circles[k, 1], circles[k, 2])
            if t < best:
                best = t
        out[i] = best if best <= max_range else math.inf


@_njit(cache=True)
def _scan_one_cone(px, py, yaw, angles, hw, net_r, poly, squares, circles, max_range, out):
    keep = np.empty(squares.shape[0] + circles.shape[0], dtype=np.int64)
    _cone_into(px, py, yaw, angles, hw, net_r, poly, 0, poly.shape[0], squares, 0, squares.shape[0],
               circles, 0, circles.shape[0], max_range, out, keep)


@_njit(cache=True)
def _scan_batch_cone(poses, angles, hw, net_r, world_of, polys, po_off, squares, sq_off, circles, ci_off,
                     max_range, out):
    keep = np.empty(squares.shape[0] + circles.shape[0], dtype=np.int64)
    for b in range(poses.shape[0]):
        w = world_of[b]
        p0, p1 = po_off[w], po_off[w + 1]
        _cone_into(poses[b, 0], poses[b, 1], poses[b, 2], angles, hw, net_r[w], polys, p0, p1, squares,
                   sq_off[w], sq_off[w + 1], circles, ci_off[w], ci_off[w + 1], max_range, out[b], keep)


@_njit(cache=True)
def _cast_beams(origins, angles, hw, net_r, poly, squares, circles, max_range, out):
    keep = np.empty(squares.shape[0] + circles.shape[0], dtype=np.int64)
    one = np.empty(1)
    ang = np.empty(1)
    for k in range(origins.shape[0]):
        ang[0] = angles[k]
        _cone_into(origins[k, 0], origins[k, 1], origins[k, 2], ang, hw, net_r, poly, 0, poly.shape[0],
                   squares, 0, squares.shape[0], circles, 0, circles.shape[0], max_range, one, keep)
        out[k] = one[0]
