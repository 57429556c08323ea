"""One mission's state machine: pose, route progress, reward and outcome. No sonar, no gym.

Shared by the single gym env, the batched env and the evaluator, so all of them judge an episode
the same way. Outcomes (``info["outcome"]``):
  goal       within ``goal_radius`` of the final waypoint;
  collision  closer than the world's safety radius to the net or any obstacle (checked at the end
             and the middle of each 1 m step);
  wander     farther than ``wander_distance`` from the current route segment (the study's
             "wandered off": the vehicle has left the corridor it was sent along);
  timeout    ``max_steps`` decisions without any of the above (episode truncated, not terminated).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from .fish import FishState
from .map_points import MapPoints
from .observation import ObservationBuilder, ObservationLayout, ObservationLayoutV2
from .scenarios import Scenario
from .sonar import Scan, SonarModel, make_sonar
from .route import RouteTracker
from .vehicle import VehicleParams, decision_step, velocity_over_ground

OUTCOMES = ("goal", "collision", "wander", "timeout")


@dataclass(frozen=True)
class RewardConfig:
    """The study's reward by default (REFERENCE.md); the extra terms are off unless set."""

    goal: float = 30.0
    collision: float = -4.0
    wander: float = -4.0
    distance_weight: float = 1.0      # r_dist = 1 - remaining / initial route length
    heading_weight: float = 1.0       # r_psi = 1 - |heading error| / pi
    overtime_factor: float = 1.5      # penalty starts after this many steps per metre of route
    overtime_penalty: float = 0.1     # ... -overtime_penalty * steps per step
    progress_weight: float = 0.0      # optional: reward per metre of route progress
    clearance_weight: float = 0.0     # optional: penalty when closer than clearance_margin
    clearance_margin: float = 2.0


OBSERVATIONS = ("auto", "v1", "v2")


@dataclass(frozen=True)
class EnvConfig:
    """Everything that defines an episode besides the scenario (the water, the net and the fish are
    the scenario's: scenarios.py families).

    sonar: a ``SonarModel``, or a profile name / dict for ``make_sonar`` ("study", "fls", ...).
    observation: "v1" (the study's layout), "v2" (sensor profile recorded, options below) or "auto"
    (v1 for the study profile without options, else v2). velocity: add the velocity over ground.
    memory_bins / memory_horizon: add the egocentric memory histogram (0 = none). scan_in_obs: keep
    the raw scan in a v2 observation (False: memory only, e.g. a 180-beam scanning head)."""

    vehicle: VehicleParams = field(default_factory=VehicleParams)
    sonar: SonarModel = field(default_factory=SonarModel)
    reward: RewardConfig = field(default_factory=RewardConfig)
    motion: str = "continuous"        # "continuous" (exact integral of the vehicle node's model) or "study"
    waypoint_scale: float = 20.0
    goal_radius: float = 1.0
    waypoint_radius: float = 2.0
    wander_distance: float = 15.0
    max_steps_factor: float = 3.0     # max_steps = factor * route length + extra
    max_steps_extra: int = 20
    observation: str = "auto"
    velocity: bool = False
    memory_bins: int = 0
    memory_horizon: float = 10.0
    scan_in_obs: bool = True

    def __post_init__(self) -> None:
        if not isinstance(self.sonar, SonarModel):
            object.__setattr__(self, "sonar", make_sonar(self.sonar))
        if self.observation not in OBSERVATIONS:
            raise ValueError(f"observation: must be one of {OBSERVATIONS}, got {self.observation!r}")
        if self.observation == "v1" and (self.velocity or self.memory_bins or not self.scan_in_obs):
            raise ValueError("observation: 'v1' has no velocity / memory options (use 'v2' or 'auto')")
        if self.memory_bins < 0:
            raise ValueError(f"memory_bins: must be >= 0, got {self.memory_bins!r}")

    @property
    def layout(self) -> "ObservationLayout | ObservationLayoutV2":
        v1 = self.observation == "v1" or (self.observation == "auto" and self.sonar.profile == "study"
                                           and not (self.velocity or self.memory_bins) and self.scan_in_obs)
        if v1:
            return ObservationLayout(self.sonar.n_beams, self.sonar.max_range, self.waypoint_scale)
        return ObservationLayoutV2.for_sonar(self.sonar, self.waypoint_scale, self.velocity, self.memory_bins,
                                             self.memory_horizon, self.scan_in_obs, 2.0 * self.vehicle.speed)


def _segment_distance(ax: float, ay: float, bx: float, by: float, px: float, py: float) -> float:
    """Distance from point p to segment ab: the goal counts as reached if a step passes through it."""
    dx, dy = bx - ax, by - ay
    n2 = dx * dx + dy * dy
    s = 0.0 if n2 == 0 else min(1.0, max(0.0, ((px - ax) * dx + (py - ay) * dy) / n2))
    return math.hypot(ax + s * dx - px, ay + s * dy - py)


def new_fish(world, seed: int = 0) -> FishState | None:
    """The world's schools at home at the start of an episode (None when it has none)."""
    return FishState(world.schools, world.net_radius, seed) if world.schools else None


def with_schools(world, fish: FishState | None):
    """``world`` as the sonar and the collision test see it with the schools where ``fish`` has them."""
    return world if fish is None else world.with_fish(fish.circles())


class Mission:
    """Judges one mission decision by decision.

    ``step(action)`` moves the vehicle with the vehicle model (the env); ``record(x, y, yaw)`` judges
    a pose that arrived from elsewhere (the simulator node, from the vehicle node's odometry at a
    decision boundary). Both go through the same checks, so the graph and the env agree.
    """

    def __init__(self, scenario: Scenario, config: EnvConfig, seed: int = 0, fish: FishState | None = None):
        """``fish``: the world's schools as they are now, carried on from an earlier mission in the same
        water (the simulator node's goal after goal), else new ones at home (wander phases from ``seed``)."""
        self.scenario, self.config = scenario, config
        self.world = scenario.world
        cmax = self.world.current_field.max_speed
        if cmax >= config.vehicle.speed:
            raise ValueError(f"current: up to {cmax:.2f} m/s is not slower than the vehicle "
                             f"({config.vehicle.speed:.2f} m/s through the water): it could not make headway")
        if fish is not None and fish.schools != tuple(self.world.schools):
            raise ValueError(f"fish: {len(fish)} schools given for a world with {len(self.world.schools)} other ones")
        self.fish = fish if fish is not None else new_fish(self.world, seed)
        self.head = config.sonar.head()
        self.builder = ObservationBuilder(config.layout)
        self.last_scan: Scan | None = None
        self.x, self.y, self.yaw = (float(v) for v in scenario.start)
        self.map_points = MapPoints.from_world(self.world)   # the known map, as the map topic carries it
        self.tracker = RouteTracker(scenario.start, scenario.route(), config.waypoint_radius, self.map_points)
        self.route = self.tracker.route
        self.route_length = self.tracker.length
        self.steps = 0
        self.t = 0.0
        self.outcome: str | None = None
        self.max_steps = int(math.ceil(config.max_steps_factor * self.route_length)) + config.max_steps_extra
        self.travelled = 0.0
        self.replans = 0
        self.track = [(self.x, self.y, self.yaw)]
        self.tracker.advance(self.x, self.y)
        self.remaining = self.tracker.remaining(self.x, self.y)

    @property
    def index(self) -> int:
        return self.tracker.index

    def waypoint(self) -> tuple[float, float]:
        """Distance (m) and body-frame heading error (rad, left positive) to the current waypoint."""
        return self.tracker.waypoint(self.x, self.y, self.yaw)

    def step(self, action: float) -> tuple[float, str | None]:
        """Apply one decision with the vehicle model; return (reward, outcome or None)."""
        x, y, yaw = decision_step(self.x, self.y, self.yaw, float(action), self.config.vehicle,
                                  self.world.current_field, self.config.motion, self.t)
        return self.record(x, y, yaw)

    def record(self, x: float, y: float, yaw: float) -> tuple[float, str | None]:
        """Judge the pose reached at the end of the next decision; return (reward, outcome or None)."""
        cfg, rw = self.config, self.config.reward
        x0, y0 = self.x, self.y
        self.x, self.y, self.yaw = float(x), float(y), float(yaw)
        self.steps += 1
        self.t = self.steps * cfg.vehicle.decision_period
        self.travelled += math.hypot(self.x - x0, self.y - y0)
        self.track.append((self.x, self.y, self.yaw))
        self.tracker.advance(self.x, self.y)
        mid = (0.5 * (x0 + self.x), 0.5 * (y0 + self.y))
        if self.fish is not None:
            self.fish.step(cfg.vehicle.decision_period, (self.x, self.y))
        scene = self.scene
        clearance = min(scene.clearance(self.x, self.y, self.t),
                        scene.clearance(*mid, self.t - 0.5 * cfg.vehicle.decision_period))

        dist, err = self.waypoint()
        remaining = self.tracker.remaining(self.x, self.y)
        reward = (rw.distance_weight * (1.0 - remaining / max(self.route_length, 1e-6))
                  + rw.heading_weight * (1.0 - abs(err) / math.pi)
                  + rw.progress_weight * (self.remaining - remaining))
        if rw.clearance_weight and clearance < rw.clearance_margin:
            reward -= rw.clearance_weight * (rw.clearance_margin - clearance) / rw.clearance_margin
        self.remaining = remaining
        if self.steps > rw.overtime_factor * self.route_length:
            reward -= rw.overtime_penalty * self.steps

        if clearance < self.world.safety_radius:
            self.outcome, reward = "collision", reward + rw.collision
        elif self.tracker.at_last and _segment_distance(x0, y0, self.x, self.y,
                                                        *self.route[-1]) < cfg.goal_radius:
            self.outcome, reward = "goal", reward + rw.goal
        elif self.tracker.segment_offset(self.x, self.y) > cfg.wander_distance:
            self.outcome, reward = "wander", reward + rw.wander
        elif self.steps >= self.max_steps:
            self.outcome = "timeout"
        return reward, self.outcome

    def replan(self, points) -> None:
        """Follow a new route from where the vehicle is (a replan): what is left of the mission is
        judged against it (waypoints, wander); the start, time and distance flown stay."""
        self.tracker = RouteTracker((self.x, self.y), points, self.config.waypoint_radius, self.map_points)
        self.tracker.advance(self.x, self.y)   # past a first waypoint at the pose itself, as policy_node's tracker
        self.route = self.tracker.route
        self.replans += 1

    @property
    def pose(self) -> tuple[float, float, float]:
        return self.x, self.y, self.yaw

    @property
    def scene(self):
        """The world as the sonar and the collision test see it now (fish schools where they are)."""
        return with_schools(self.world, self.fish)

    def current_here(self) -> tuple[float, float]:
        """Water velocity (map frame, m/s) at the vehicle now."""
        return self.world.current_field.velocity(self.x, self.y, self.t)

    def velocity_over_ground(self) -> tuple[float, float]:
        """Body-frame (forward, left) velocity over ground now, as a DVL would report it."""
        return velocity_over_ground(self.yaw, self.config.vehicle.speed, self.current_here())

    def info(self) -> dict:
        return {"outcome": self.outcome, "is_success": self.outcome == "goal", "steps": self.steps,
                "waypoint_index": self.index, "route_length": self.route_length, "travelled": self.travelled,
                "pose": (self.x, self.y, self.yaw), "time": self.t}

    def observe(self, ranges: "np.ndarray | Scan") -> np.ndarray:
        """The observation from this decision's scan (a ``Scan``, or plain ranges taken from this pose)."""
        d, e = self.waypoint()
        if isinstance(self.builder.layout, ObservationLayout):
            r = ranges.ranges if isinstance(ranges, Scan) else ranges
            return self.builder.layout.build(r, d, e)
        scan = ranges if isinstance(ranges, Scan) else \
            (self.last_scan if self.last_scan is not None and ranges is self.last_scan.ranges else None)
        v = self.velocity_over_ground() if self.config.velocity else None
        if scan is None:
            return self.builder.build(ranges, self.x, self.y, self.yaw, self.t, d, e, v)
        return self.builder.build_scan(scan, self.x, self.y, self.yaw, self.t, d, e, v)

    def sense(self, rng: np.random.Generator | None = None) -> Scan:
        """This decision's scan from the sonar head (stateful for a mechanical head)."""
        head, args = self.head, (self.scene, self.x, self.y, self.yaw, self.t, rng)
        self.last_scan = head.update(*args) if head.last is not None else head.reset(*args)
        return self.last_scan

    def scan(self, rng: np.random.Generator | None = None) -> np.ndarray:
        return self.sense(rng).ranges


def noise_stream(scenario: Scenario) -> np.random.Generator:
    """A mission's own sonar-noise generator, seeded by its start pose and goal (the bits of the
    floats). Why: with one generator shared by a batch, a mission's noise (and so its flight) hung on
    which missions flew beside it, so a failed mission could not be flown again alone."""
    key = np.array([*scenario.start, *scenario.goal], dtype=np.float64).view(np.uint64)
    return np.random.default_rng([int(k) for k in key])


Noise = np.random.Generator | Sequence[np.random.Generator] | None


def observe_batch(config: EnvConfig, missions: list[Mission], rng: Noise = None) -> np.ndarray:
    """Observations of many missions at once: one batched sonar call (each in its own world) for an
    electronic sonar with the v1 layout; otherwise each mission's own head and builder (same code as
    ``CageNavEnv``). ``rng``: one generator for the whole batch, one per mission (``noise_stream``:
    each mission's noise then does not depend on the batch), or None (no noise)."""
    layout = config.layout
    if not config.sonar.noisy:
        rng = None
    own = rng is not None and not isinstance(rng, np.random.Generator)
    rngs = list(rng) if own else [rng] * len(missions)
    if config.sonar.mechanical:
        return np.stack([m.observe(m.sense(g)) for m, g in zip(missions, rngs)])
    poses = np.array([m.pose for m in missions])
    t = np.array([m.t for m in missions])
    if own:
        ranges = config.sonar.scan_batch([m.scene for m in missions], poses, t)
        ranges = np.stack([config.sonar.corrupt(r, g) for r, g in zip(ranges, rngs)])
    else:
        ranges = config.sonar.scan_batch([m.scene for m in missions], poses, t, rng)
    if not isinstance(layout, ObservationLayout):
        out = []
        for m, r in zip(missions, ranges):
            n = len(r)
            m.last_scan = m.head.last = Scan(r, config.sonar.angles, np.full(n, m.t), np.tile(m.pose, (n, 1)),
                                             np.ones(n, dtype=bool))
            out.append(m.observe(m.last_scan))
        return np.stack(out)
    wp = np.array([m.waypoint() for m in missions])
    return layout.build(ranges, wp[:, 0], wp[:, 1])
