"""Scenarios: seeded generators (the study's 2D case, the full cage) and strict YAML files.

A scenario is a world plus a start pose, a goal and optionally the waypoints to follow. Named
scenarios (``SCENARIOS``) are either generators, drawing a fresh scenario from a seeded
``numpy.random.Generator`` at every episode, or files shipped in ``cage_sim/scenarios/``.
The YAML schema is documented in the README; ``load_scenario`` rejects unknown keys, wrong types
and impossible geometry with a message that names the field.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from importlib import resources
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np
import yaml

from .current import CurrentMode, random_field
from .escape import escapable
from .fish import FishSchool
from .net import MAX_LOSS
from .world import Obstacle, World

Point = tuple[float, float]


@dataclass(frozen=True)
class Scenario:
    """A mission: world, start pose (x, y, yaw rad), goal (x, y), optional waypoints (goal last)."""

    name: str
    world: World
    start: tuple[float, float, float]
    goal: Point
    waypoints: tuple[Point, ...] | None = None
    sensor: str | None = None      # sensor profile the scenario asks for (None: the caller's choice)

    def route(self) -> np.ndarray:
        """The points the vehicle should pass, in order, ending at the goal."""
        if self.waypoints:
            pts = [tuple(p) for p in self.waypoints]
            if math.dist(pts[-1], self.goal) > 1e-6:
                pts.append(tuple(self.goal))
            return np.asarray(pts, dtype=float)
        return np.asarray([self.goal], dtype=float)

    def with_waypoints(self, waypoints: Sequence[Sequence[float]]) -> "Scenario":
        return replace(self, waypoints=tuple((float(p[0]), float(p[1])) for p in waypoints))

    def validate(self) -> None:
        """Raise ScenarioError naming the field when start or goal is not a legal place."""
        w = self.world
        for fname, (x, y) in (("start", self.start[:2]), ("goal", self.goal)):
            if not (math.isfinite(x) and math.isfinite(y)):
                raise ScenarioError(f"{fname}: coordinates must be finite, got ({x}, {y})")
            if not w.inside_net(x, y, w.safety_radius):
                raise ScenarioError(f"{fname}: ({x:.2f}, {y:.2f}) is outside the net "
                                    f"(radius {w.net_radius} minus safety radius {w.safety_radius})")
            if w.in_collision(x, y):
                raise ScenarioError(f"{fname}: ({x:.2f}, {y:.2f}) is inside an obstacle "
                                    f"(clearance {w.clearance(x, y):.2f} m < safety radius {w.safety_radius} m)")

    def to_dict(self) -> dict:
        w = self.world
        d: dict[str, Any] = {
            "name": self.name, "net_radius": w.net_radius, "safety_radius": w.safety_radius,
            "current": list(w.current),
            "start": [self.start[0], self.start[1], math.degrees(self.start[2])],
            "goal": list(self.goal),
            "known_obstacles": [_obstacle_dict(o) for o in w.known],
            "unknown_obstacles": [_obstacle_dict(o) for o in w.unknown],
        }
        if self.waypoints:
            d["waypoints"] = [list(p) for p in self.waypoints]
        if w.current_modes:
            d["current_modes"] = [{k: getattr(m, k) for k in _MODE_KEYS} for m in w.current_modes]
        if math.isfinite(w.current_cap):
            d["current_cap"] = w.current_cap
        if w.net_loss != 0.0:
            d["net_deformation"] = "auto" if w.net_loss is None else w.net_loss
        if w.schools:
            d["fish_schools"] = [{k: getattr(f, k) for k in _SCHOOL_KEYS} for f in w.schools]
        if self.sensor:
            d["sensor"] = self.sensor
        return d


class ScenarioError(ValueError):
    """An invalid scenario; the message starts with the offending field."""


def _obstacle_dict(o: Obstacle) -> dict:
    d = {"shape": o.shape, "x": round(o.x, 4), "y": round(o.y, 4), "size": round(o.size, 4)}
    if o.moving:
        d.update(ax=round(o.ax, 4), ay=round(o.ay, 4), period=round(o.period, 4))
    return d


# --------------------------------------------------------------------------- YAML files

_TOP_KEYS = {"name": str, "net_radius": float, "safety_radius": float, "current": list,
             "start": list, "goal": list, "waypoints": list, "known_obstacles": list,
             "unknown_obstacles": list, "current_modes": list, "current_cap": float,
             "net_deformation": object, "fish_schools": list, "sensor": str}
_MODE_KEYS = {"ax": float, "ay": float, "kx": float, "ky": float, "omega": float, "phase": float}
_SCHOOL_KEYS = {"x": float, "y": float, "radius": float, "flee_radius": float, "flee_speed": float,
                "return_speed": float, "wander": float, "wander_period": float}
MAX_CURRENT = 0.9   # m/s: a current must stay below the vehicle's 1 m/s through the water
_REQUIRED = ("start", "goal")
_OBSTACLE_KEYS = {"shape": str, "x": float, "y": float, "size": float, "ax": float, "ay": float,
                  "period": float}


def _typed(value: Any, kind: type, where: str) -> Any:
    if kind is object:
        return value
    if kind is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ScenarioError(f"{where}: expected a number, got {value!r}")
        if not math.isfinite(value):
            raise ScenarioError(f"{where}: must be finite, got {value!r}")
        return float(value)
    if not isinstance(value, kind):
        raise ScenarioError(f"{where}: expected {kind.__name__}, got {type(value).__name__} {value!r}")
    return value


def _point(value: Any, where: str, n: int) -> tuple[float, ...]:
    if not isinstance(value, list) or len(value) != n:
        raise ScenarioError(f"{where}: expected a list of {n} numbers, got {value!r}")
    return tuple(_typed(v, float, f"{where}[{i}]") for i, v in enumerate(value))


def _obstacles(items: list, where: str) -> tuple[Obstacle, ...]:
    return _records(items, _OBSTACLE_KEYS, ("shape", "x", "y", "size"), where, Obstacle)


def _records(items: list, keys: dict, required: tuple[str, ...], where: str, make) -> tuple:
    out = []
    for i, item in enumerate(items):
        here = f"{where}[{i}]"
        if not isinstance(item, dict):
            raise ScenarioError(f"{here}: expected a mapping, got {item!r}")
        for key in item:
            if key not in keys:
                raise ScenarioError(f"{here}.{key}: unknown key (allowed: {', '.join(keys)})")
        for key in required:
            if key not in item:
                raise ScenarioError(f"{here}.{key}: missing")
        vals = {k: _typed(v, keys[k], f"{here}.{k}") for k, v in item.items()}
        try:
            out.append(make(**vals))
        except ValueError as err:
            field_ = str(err).split(" must")[0].split()[-1]
            raise ScenarioError(f"{here}.{field_}: {err}") from None
    return tuple(out)


def _net_deformation(value: Any) -> float | None:
    if value == "auto":
        return None
    v = _typed(value, float, "net_deformation")
    if not 0.0 <= v <= MAX_LOSS:
        raise ScenarioError(f"net_deformation: an area loss in [0, {MAX_LOSS}] or 'auto', got {value!r}")
    return v


def check_water(world: World, where: str = "current") -> None:
    """Field-named errors for water a 1 m/s vehicle cannot work in."""
    speed = math.hypot(*world.current)
    if speed > MAX_CURRENT:
        raise ScenarioError(f"{where}: {speed:.2f} m/s is as fast as the vehicle or nearly (limit {MAX_CURRENT} m/s)")
    if world.current_field.max_speed > MAX_CURRENT:
        raise ScenarioError(f"current_modes: uniform + modes reach {world.current_field.max_speed:.2f} m/s, "
                            f"above {MAX_CURRENT} m/s (set current_cap)")


def scenario_from_dict(data: Any, default_name: str = "scenario") -> Scenario:
    """Build and validate a scenario from parsed YAML (see the README for the schema)."""
    if not isinstance(data, dict):
        raise ScenarioError(f"(top level): expected a mapping, got {type(data).__name__}")
    for key in data:
        if key not in _TOP_KEYS:
            raise ScenarioError(f"{key}: unknown key (allowed: {', '.join(_TOP_KEYS)})")
    for key in _REQUIRED:
        if key not in data:
            raise ScenarioError(f"{key}: missing")
    vals = {k: _typed(v, _TOP_KEYS[k], k) for k, v in data.items()}
    start = _point(vals["start"], "start", 3)
    goal = _point(vals["goal"], "goal", 2)
    current = _point(vals.get("current", [0.0, 0.0]), "current", 2)
    waypoints = tuple(_point(p, f"waypoints[{i}]", 2) for i, p in enumerate(vals.get("waypoints", [])))
    modes = _records(vals.get("current_modes", []), _MODE_KEYS, ("ax", "ay"), "current_modes", CurrentMode)
    schools = _records(vals.get("fish_schools", []), _SCHOOL_KEYS, ("x", "y"), "fish_schools", FishSchool)
    cap = vals.get("current_cap", math.inf)
    if not cap > 0:
        raise ScenarioError(f"current_cap: must be > 0 m/s, got {cap!r}")
    loss = _net_deformation(vals["net_deformation"]) if "net_deformation" in vals else 0.0
    sensor = vals.get("sensor")
    if sensor is not None:
        from .sonar import PROFILE_NAMES
        if sensor not in PROFILE_NAMES:
            raise ScenarioError(f"sensor: must be one of {PROFILE_NAMES}, got {sensor!r}")
    try:
        world = World(net_radius=vals.get("net_radius", 30.0),
                      known=_obstacles(vals.get("known_obstacles", []), "known_obstacles"),
                      unknown=_obstacles(vals.get("unknown_obstacles", []), "unknown_obstacles"),
                      current=current, safety_radius=vals.get("safety_radius", 0.5),
                      current_modes=modes, current_cap=cap, net_loss=loss, schools=schools)
    except ScenarioError:
        raise
    except ValueError as err:
        raise ScenarioError(f"net_radius/safety_radius: {err}") from None
    check_water(world)
    sc = Scenario(vals.get("name", default_name), world, (start[0], start[1], math.radians(start[2])),
                  goal, waypoints or None, sensor)
    sc.validate()
    for i, p in enumerate(waypoints):
        if not world.inside_net(*p, world.safety_radius):
            raise ScenarioError(f"waypoints[{i}]: ({p[0]:.2f}, {p[1]:.2f}) is outside the net")
    return sc


def load_scenario(path: str | Path) -> Scenario:
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as err:
        raise ScenarioError(f"(file {path}): not valid YAML: {err}") from None
    return scenario_from_dict(data, default_name=path.stem)


def save_scenario(sc: Scenario, path: str | Path) -> None:
    Path(path).write_text(yaml.safe_dump(sc.to_dict(), sort_keys=False))


# --------------------------------------------------------------------------- generators

@dataclass(frozen=True)
class CageParams:
    """Knobs of the full-cage generator (defaults: the study's cage plus 10 unknown obstacles)."""

    net_radius: float = 30.0
    safety_radius: float = 0.5
    n_known: int = 20
    known_size: float = 2.0
    n_unknown: int = 10
    n_moving: int = 0
    current_speed: float = 0.0
    min_route: float = 20.0
    min_gap: float = 2.0          # free water kept between any two obstacles (so no pocket closes)
    on_route_fraction: float = 0.5  # unknown obstacles placed near the straight start-goal line
    # --- sea-ready knobs (defaults leave every draw above exactly as before) ---
    current_max: float | None = None        # current speed uniform in [current_speed, current_max]
    current_variation: float = 0.0          # slowly varying modes, amplitude sum = variation * speed
    net_deformation: float | None = 0.0     # area loss; None = from the current (net.py)
    obstacle_size: tuple[float, float] | None = None  # unknown static obstacles: circle radius /
    #                                                   square half-side range (m), e.g. (0.15, 0.3)
    goal_wall: float | None = None          # goal this far (m) from the nominal net wall, e.g. 2.5
    n_schools: int = 0                      # fleeing fish schools (fish.py)
    sensor: str | None = None               # sensor profile recorded in the scenario

    def __post_init__(self) -> None:
        def bad(name: str, msg: str) -> ScenarioError:
            return ScenarioError(f"{name}: {msg}, got {getattr(self, name)!r}")
        for name in ("n_known", "n_unknown", "n_moving", "n_schools"):
            if getattr(self, name) < 0:
                raise bad(name, "must be >= 0")
        if not 0 <= self.current_speed <= MAX_CURRENT:
            raise bad("current_speed", f"must be in [0, {MAX_CURRENT}] m/s (negative, or as fast as the vehicle)")
        if self.current_max is not None and not self.current_speed <= self.current_max <= MAX_CURRENT:
            raise bad("current_max", f"must be in [current_speed, {MAX_CURRENT}] m/s")
        top = (self.current_max or self.current_speed) * (1 + self.current_variation)
        if not 0 <= self.current_variation <= 1 or top > MAX_CURRENT:
            raise bad("current_variation", f"must be in [0, 1] with speed * (1 + variation) <= {MAX_CURRENT}")
        if self.net_deformation is not None and not 0 <= self.net_deformation <= MAX_LOSS:
            raise bad("net_deformation", f"must be an area loss in [0, {MAX_LOSS}] or None (from the current)")
        if self.obstacle_size is not None:
            lo, hi = self.obstacle_size
            if not 0 < lo <= hi:
                raise bad("obstacle_size", "must be (low, high) radii with 0 < low <= high")
        if self.goal_wall is not None and not self.safety_radius < self.goal_wall < self.net_radius / 2:
            raise bad("goal_wall", "must be between the safety radius and half the net radius (m)")
        if self.sensor is not None:
            from .sonar import PROFILE_NAMES
            if self.sensor not in PROFILE_NAMES:
                raise bad("sensor", f"must be one of {PROFILE_NAMES}")


def _free_point(rng, radius, taken, bound, gap, tries=500):
    """A centre inside ``radius`` at least ``gap`` from every (centre, bound) in ``taken``."""
    for _ in range(tries):
        r, a = radius * math.sqrt(rng.random()), rng.uniform(-math.pi, math.pi)
        p = (r * math.cos(a), r * math.sin(a))
        if all(math.dist(p, c) >= b + bound + gap for c, b in taken):
            return p
    return None


def generate_cage(rng: np.random.Generator, p: CageParams = CageParams(), name: str = "cage") -> Scenario:
    """The full cage: known squares on the map, start/goal far apart, unknown obstacles (about half
    on the straight route, where they matter), optional moving fish schools and a current. A start
    no sequence of decisions leads out of a collision from (``escape.escapable``: a strong current
    pushing the vehicle into an obstacle it points at) is drawn again."""
    for _ in range(100):
        taken: list[tuple[Point, float]] = []
        known = []
        half_diag = p.known_size * math.sqrt(0.5)
        for _ in range(p.n_known):
            c = _free_point(rng, p.net_radius - half_diag - p.min_gap, taken, half_diag, p.min_gap)
            if c is None:
                break
            taken.append((c, half_diag))
            known.append(Obstacle("square", c[0], c[1], p.known_size))
        keep_clear = 2.5
        start = _free_point(rng, p.net_radius - 5.0, taken, keep_clear, 0.0)
        if p.goal_wall is None:
            goal = _free_point(rng, p.net_radius - 5.0, taken, keep_clear, 0.0)
        else:
            goal = _wall_point(rng, p.net_radius - p.goal_wall, taken, keep_clear)
        if start is None or goal is None or math.dist(start, goal) < p.min_route or len(known) < p.n_known:
            continue
        taken_sg = taken + [(start, keep_clear), (goal, keep_clear)]
        unknown = _unknown_obstacles(rng, p, start, goal, taken_sg)
        if len(unknown) < p.n_unknown + p.n_moving:
            continue
        heading = math.atan2(goal[1] - start[1], goal[0] - start[0]) + rng.uniform(-math.pi / 2, math.pi / 2)
        ang = rng.uniform(-math.pi, math.pi)
        current = (p.current_speed * math.cos(ang), p.current_speed * math.sin(ang))
        extra: dict[str, Any] = {}
        if p.current_max is not None or p.current_variation or p.net_deformation != 0.0 or p.n_schools:
            speed = rng.uniform(p.current_speed, p.current_max) if p.current_max is not None else p.current_speed
            field_ = random_field(rng, speed, 2 if p.current_variation else 0, p.current_variation)
            current = (speed * math.cos(ang), speed * math.sin(ang))
            extra = dict(current_modes=field_.modes, current_cap=field_.cap, net_loss=p.net_deformation,
                         schools=_schools(rng, p, start, goal, taken_sg + [(u.centre(), u.bound) for u in unknown]))
            if len(extra["schools"]) < p.n_schools:
                continue
        world = World(p.net_radius, tuple(known), tuple(unknown), current, p.safety_radius, **extra)
        if world.net.deformed:
            if p.goal_wall is not None:   # near the wall the sonar sees, not the nominal one
                goal = world.net.inward(math.atan2(goal[1], goal[0]), p.goal_wall)
                if world.clearance(*goal) < min(keep_clear, p.goal_wall) - 0.02 or math.dist(start, goal) < p.min_route:
                    continue
            if world.net.clearance(*start) < keep_clear or world.net.clearance(*goal) < min(keep_clear, p.goal_wall or keep_clear) - 0.02:
                continue   # the pushed-in wall took the start or the goal: draw again
        pose = (start[0], start[1], math.atan2(math.sin(heading), math.cos(heading)))
        if not escapable(world, pose):
            continue   # a current pushes the vehicle into an obstacle whatever it does: draw again (escape.py)
        return Scenario(name, world, pose, goal, sensor=p.sensor)
    raise RuntimeError("could not place a cage scenario; loosen CageParams")


def _wall_point(rng, radius: float, taken, keep_clear: float):
    """A point on the circle of ``radius`` (a goal near the net) clear of the obstacles."""
    for _ in range(500):
        a = rng.uniform(-math.pi, math.pi)
        q = (radius * math.cos(a), radius * math.sin(a))
        if all(math.dist(q, c) >= b + keep_clear for c, b in taken):
            return q
    return None


def _schools(rng, p: CageParams, start, goal, taken) -> tuple[FishSchool, ...]:
    """Fleeing schools: radius 1-1.5 m, homes clear of everything (they drift and flee from there)."""
    out = []
    for _ in range(p.n_schools):
        radius = rng.uniform(1.0, 1.5)
        for _ in range(300):
            c = _free_point(rng, p.net_radius - radius - 3.0, [], 0.0, 0.0)
            if all(math.dist(c, q) >= b + radius + 1.0 for q, b in taken):
                break
        else:
            continue
        taken = taken + [(c, radius + 2.0)]
        out.append(FishSchool(c[0], c[1], radius, flee_radius=rng.uniform(3.0, 5.0), flee_speed=rng.uniform(0.5, 1.0),
                              return_speed=rng.uniform(0.1, 0.3), wander=rng.uniform(1.0, 3.0),
                              wander_period=rng.uniform(30.0, 90.0)))
    return tuple(out)


def _unknown_obstacles(rng, p: CageParams, start, goal, taken) -> list[Obstacle]:
    out = []
    sx, sy = start
    gx, gy = goal
    for i in range(p.n_unknown + p.n_moving):
        moving = i >= p.n_unknown
        if moving:
            shape, size = "circle", rng.uniform(1.0, 1.5)
            amp, period = rng.uniform(2.0, 4.0), rng.uniform(20.0, 40.0)
        elif p.obstacle_size is not None:
            r = rng.uniform(*p.obstacle_size)
            shape, amp, period = ("circle", 0.0, 0.0) if rng.random() < 0.5 else ("square", 0.0, 0.0)
            size = r if shape == "circle" else 2.0 * r
        elif rng.random() < 0.5:
            shape, size, amp, period = "circle", rng.uniform(0.3, 1.0), 0.0, 0.0
        else:
            shape, size, amp, period = "square", rng.uniform(1.0, 2.0), 0.0, 0.0
        bound = (size * math.sqrt(0.5) if shape == "square" else size) + amp
        gap = 1.0 if moving else p.min_gap   # a drifting school may sweep closer to fixed things
        for _ in range(300):
            if rng.random() < p.on_route_fraction:
                s = rng.uniform(0.2, 0.8)
                off = rng.uniform(-2.0, 2.0)
                n = math.dist(start, goal)
                c = (sx + s * (gx - sx) - off * (gy - sy) / n, sy + s * (gy - sy) + off * (gx - sx) / n)
            else:
                c = _free_point(rng, p.net_radius - bound - p.min_gap, [], 0.0, 0.0)
            if math.hypot(*c) + bound + gap <= p.net_radius and \
                    all(math.dist(c, q) >= b + bound + gap for q, b in taken):
                break
        else:
            continue
        dir_ = rng.uniform(-math.pi, math.pi)
        taken.append((c, bound))
        out.append(Obstacle(shape, c[0], c[1], size, amp * math.cos(dir_), amp * math.sin(dir_), period))
    return out


def generate_study2d(rng: np.random.Generator, net_radius: float = 30.0, name: str = "study2d") -> Scenario:
    """The study's 2D case, as we read it: random start, heading and goal (15-35 m apart, inside the
    cage) and one 2 x 2 m obstacle near the straight line between them, 30-70 % of the way along."""
    while True:
        r0, r1 = 22.0 * math.sqrt(rng.random()), 22.0 * math.sqrt(rng.random())
        a0, a1 = rng.uniform(-math.pi, math.pi, 2)
        start = (r0 * math.cos(a0), r0 * math.sin(a0))
        goal = (r1 * math.cos(a1), r1 * math.sin(a1))
        d = math.dist(start, goal)
        if 15.0 <= d <= 35.0:
            break
    s, off = rng.uniform(0.3, 0.7), rng.uniform(-1.5, 1.5)
    ux, uy = (goal[0] - start[0]) / d, (goal[1] - start[1]) / d
    c = (start[0] + s * d * ux - off * uy, start[1] + s * d * uy + off * ux)
    world = World(net_radius, (), (Obstacle("square", c[0], c[1], 2.0),), (0.0, 0.0), 0.5)
    yaw = rng.uniform(-math.pi, math.pi)
    return Scenario(name, world, (start[0], start[1], yaw), goal)


# --------------------------------------------------------------------------- names

Sampler = Callable[[np.random.Generator], Scenario]


def _file_sampler(filename: str) -> Sampler:
    def sample(rng: np.random.Generator) -> Scenario:
        return builtin_file(filename)
    return sample


def builtin_file(filename: str) -> Scenario:
    """A scenario file shipped in the package (``cage_sim/scenarios/``)."""
    with resources.as_file(resources.files("cage_sim") / "scenarios" / filename) as p:
        return load_scenario(p)


SCENARIOS: dict[str, Sampler] = {
    "study2d": generate_study2d,
    "cage": lambda rng: generate_cage(rng),
    "cage_moving": lambda rng: generate_cage(rng, CageParams(n_moving=3, current_speed=0.1), "cage_moving"),
    "full_cage": _file_sampler("full_cage.yaml"),
    "sea_cage": _file_sampler("sea_cage.yaml"),
}


# --------------------------------------------------------------------------- families

OBSTACLE_SIZES = {"default": None, "small": (0.15, 0.3), "mixed": (0.15, 1.0)}
FAMILY_BASES = ("cage", "cage_moving")
FAMILY_KEYS = ("current", "variation", "net", "obstacles", "goal", "schools", "sensor", "known", "unknown")


def _range(value: str, key: str, spec: str) -> tuple[float, float]:
    try:
        lo, _, hi = value.partition("-")
        lo_f = float(lo)
        hi_f = float(hi) if hi else lo_f
    except ValueError:
        raise ScenarioError(f"scenario family {spec!r}: {key}: expected a number or a range 'a-b', got {value!r}") from None
    if not (math.isfinite(lo_f) and math.isfinite(hi_f)) or hi_f < lo_f:
        raise ScenarioError(f"scenario family {spec!r}: {key}: bad range {value!r}")
    return lo_f, hi_f


def family_params(spec: "str | dict") -> tuple[str, CageParams]:
    """Parse a family: ``"cage?current=0.5&obstacles=small&goal=near_net&schools=3&sensor=fls"`` or
    the same as a dict ``{"base": "cage", "current": 0.5, ...}``. Keys (all optional):
      current    inside-pen speed m/s, or a range "0.15-0.25" (drawn per scenario); default 0
      variation  slowly varying part, fraction of the speed (default 0.2 when current > 0)
      net        "auto" (deformed by the current, default when current > 0), "none", or an area loss
      obstacles  "default" (the study's sizes), "small" (radius 0.15-0.3 m), "mixed" (0.15-1.0), or "a-b"
      goal       "any" (default) or "near_net" (2.5 m from the wall) or a distance "3.0"
      schools    number of fleeing fish schools (default 0)
      sensor     sensor profile recorded in each scenario (study, multibeam360, fls, scanning)
      known / unknown  numbers of known / unknown obstacles
    Returns (base name, CageParams); errors name the key."""
    if isinstance(spec, dict):
        d = {k: str(v) for k, v in spec.items() if k != "base"}
        base, text = str(spec.get("base", "cage")), "&".join(f"{k}={v}" for k, v in d.items())
        spec = f"{base}?{text}" if text else base
    base, _, query = spec.partition("?")
    if base not in FAMILY_BASES:
        raise ScenarioError(f"scenario family {spec!r}: base: must be one of {FAMILY_BASES}, got {base!r}")
    kv: dict[str, str] = {}
    for part in filter(None, query.split("&")):
        k, eq, v = part.partition("=")
        if not eq or k not in FAMILY_KEYS:
            raise ScenarioError(f"scenario family {spec!r}: {k}: unknown key (allowed: {', '.join(FAMILY_KEYS)})")
        kv[k] = v
    p = CageParams(n_moving=3, current_speed=0.1) if base == "cage_moving" else CageParams()
    changes: dict[str, Any] = {}
    if "current" in kv:
        lo, hi = _range(kv["current"], "current", spec)
        if lo < 0:
            raise ScenarioError(f"scenario family {spec!r}: current: speed must be >= 0, got {kv['current']!r}")
        changes.update(current_speed=lo, current_max=hi if hi > lo else None)
    moving_water = changes.get("current_max") or changes.get("current_speed", 0.0) > 0
    try:
        var = float(kv.get("variation", 0.2 if moving_water else 0.0))
    except ValueError:
        raise ScenarioError(f"scenario family {spec!r}: variation: expected a number, got {kv['variation']!r}") from None
    changes["current_variation"] = var
    net = kv.get("net", "auto" if moving_water else "none")
    if net == "auto":
        changes["net_deformation"] = None
    elif net == "none":
        changes["net_deformation"] = 0.0
    else:
        changes["net_deformation"] = _range(net, "net", spec)[0]
    obs = kv.get("obstacles", "default")
    changes["obstacle_size"] = OBSTACLE_SIZES[obs] if obs in OBSTACLE_SIZES else _range(obs, "obstacles", spec)
    goal = kv.get("goal", "any")
    if goal != "any":
        changes["goal_wall"] = 2.5 if goal == "near_net" else _range(goal, "goal", spec)[0]
    for key, name in (("schools", "n_schools"), ("known", "n_known"), ("unknown", "n_unknown")):
        if key in kv:
            if not kv[key].isdigit():
                raise ScenarioError(f"scenario family {spec!r}: {key}: expected a whole number, got {kv[key]!r}")
            changes[name] = int(kv[key])
    if "sensor" in kv:
        changes["sensor"] = kv["sensor"]
    try:
        return base, replace(p, **changes)
    except ScenarioError as err:
        raise ScenarioError(f"scenario family {spec!r}: {err}") from None


def make_generator(spec: "str | dict") -> Sampler:
    """A sampler for a named family (see ``family_params``): the trainer's domain randomisation and the
    evaluator's matrix both draw from it. A bare base name without a query is the registered one."""
    if isinstance(spec, str) and spec in SCENARIOS and "?" not in spec:
        return SCENARIOS[spec]
    base, params = family_params(spec)
    name = spec if isinstance(spec, str) else base

    def sample(rng: np.random.Generator) -> Scenario:
        return generate_cage(rng, params, name)
    sample.params = params        # type: ignore[attr-defined]
    return sample


def family_sensor(spec: "str | dict") -> str | None:
    """The sensor profile a family names (``sensor=...``), None when it leaves it to the caller."""
    if isinstance(spec, (str, dict)) and ("?" in str(spec) or isinstance(spec, dict)):
        return family_params(spec)[1].sensor
    return None


def scenario_sampler(spec: "str | Path | Scenario | Sampler") -> Sampler:
    """Resolve a scenario name, a family ("cage?current=0.5&..."), a YAML path, a fixed Scenario or a
    sampler to a sampler."""
    if isinstance(spec, Scenario):
        return lambda rng: spec
    if callable(spec):
        return spec
    if isinstance(spec, dict):
        return make_generator(spec)
    if isinstance(spec, str) and spec in SCENARIOS:
        return SCENARIOS[spec]
    if isinstance(spec, str) and "?" in spec:
        return make_generator(spec)
    path = Path(spec)
    if path.suffix in (".yaml", ".yml"):
        sc = load_scenario(path)
        return lambda rng: sc
    raise ScenarioError(f"scenario: {spec!r} is neither a known name ({', '.join(SCENARIOS)}) nor a YAML file")


def draw_scenario(spec: "str | Path | Scenario | Sampler", seed: int = 0) -> Scenario:
    """The scenario ``CageNavEnv(spec).reset(seed=seed)`` starts from (Gymnasium seeds its generator
    as ``np.random.default_rng(seed)``), so a node given the same name and seed runs the same mission."""
    return scenario_sampler(spec)(np.random.default_rng(seed))
