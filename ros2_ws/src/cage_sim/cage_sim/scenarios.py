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
             "unknown_obstacles": list}
_REQUIRED = ("start", "goal")
_OBSTACLE_KEYS = {"shape": str, "x": float, "y": float, "size": float, "ax": float, "ay": float,
                  "period": float}


def _typed(value: Any, kind: type, where: str) -> Any:
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
    out = []
    for i, item in enumerate(items):
        here = f"{where}[{i}]"
        if not isinstance(item, dict):
            raise ScenarioError(f"{here}: expected a mapping, got {item!r}")
        for key in item:
            if key not in _OBSTACLE_KEYS:
                raise ScenarioError(f"{here}.{key}: unknown key (allowed: {', '.join(_OBSTACLE_KEYS)})")
        for key in ("shape", "x", "y", "size"):
            if key not in item:
                raise ScenarioError(f"{here}.{key}: missing")
        vals = {k: _typed(v, _OBSTACLE_KEYS[k], f"{here}.{k}") for k, v in item.items()}
        try:
            out.append(Obstacle(**vals))
        except ValueError as err:
            raise ScenarioError(f"{here}: {err}") from None
    return tuple(out)


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
    try:
        world = World(net_radius=vals.get("net_radius", 30.0),
                      known=_obstacles(vals.get("known_obstacles", []), "known_obstacles"),
                      unknown=_obstacles(vals.get("unknown_obstacles", []), "unknown_obstacles"),
                      current=current, safety_radius=vals.get("safety_radius", 0.5))
    except ScenarioError:
        raise
    except ValueError as err:
        raise ScenarioError(f"net_radius/safety_radius: {err}") from None
    sc = Scenario(vals.get("name", default_name), world, (start[0], start[1], math.radians(start[2])),
                  goal, waypoints or None)
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
    on the straight route, where they matter), optional moving fish schools and a current."""
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
        goal = _free_point(rng, p.net_radius - 5.0, taken, keep_clear, 0.0)
        if start is None or goal is None or math.dist(start, goal) < p.min_route or len(known) < p.n_known:
            continue
        taken_sg = taken + [(start, keep_clear), (goal, keep_clear)]
        unknown = _unknown_obstacles(rng, p, start, goal, taken_sg)
        if len(unknown) < p.n_unknown + p.n_moving:
            continue
        heading = math.atan2(goal[1] - start[1], goal[0] - start[0]) + rng.uniform(-math.pi / 2, math.pi / 2)
        ang = rng.uniform(-math.pi, math.pi)
        current = (p.current_speed * math.cos(ang), p.current_speed * math.sin(ang))
        world = World(p.net_radius, tuple(known), tuple(unknown), current, p.safety_radius)
        return Scenario(name, world, (start[0], start[1], math.atan2(math.sin(heading), math.cos(heading))), goal)
    raise RuntimeError("could not place a cage scenario; loosen CageParams")


def _unknown_obstacles(rng, p: CageParams, start, goal, taken) -> list[Obstacle]:
    out = []
    sx, sy = start
    gx, gy = goal
    for i in range(p.n_unknown + p.n_moving):
        moving = i >= p.n_unknown
        if moving:
            shape, size = "circle", rng.uniform(1.0, 1.5)
            amp, period = rng.uniform(2.0, 4.0), rng.uniform(20.0, 40.0)
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
}


def scenario_sampler(spec: "str | Path | Scenario | Sampler") -> Sampler:
    """Resolve a scenario name, a YAML path, a fixed Scenario or a sampler to a sampler."""
    if isinstance(spec, Scenario):
        return lambda rng: spec
    if callable(spec):
        return spec
    if isinstance(spec, str) and spec in SCENARIOS:
        return SCENARIOS[spec]
    path = Path(spec)
    if path.suffix in (".yaml", ".yml"):
        sc = load_scenario(path)
        return lambda rng: sc
    raise ScenarioError(f"scenario: {spec!r} is neither a known name ({', '.join(SCENARIOS)}) nor a YAML file")


def draw_scenario(spec: "str | Path | Scenario | Sampler", seed: int = 0) -> Scenario:
    """The scenario ``CageNavEnv(spec).reset(seed=seed)`` starts from (Gymnasium seeds its generator
    as ``np.random.default_rng(seed)``), so a node given the same name and seed runs the same mission."""
    return scenario_sampler(spec)(np.random.default_rng(seed))
