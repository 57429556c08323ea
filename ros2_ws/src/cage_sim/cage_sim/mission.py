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

import numpy as np

from .observation import ObservationLayout
from .scenarios import Scenario
from .sonar import SonarModel
from .vehicle import VehicleParams, decision_step, wrap_angle

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


@dataclass(frozen=True)
class EnvConfig:
    """Everything that defines an episode besides the scenario."""

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

    @property
    def layout(self) -> ObservationLayout:
        return ObservationLayout(self.sonar.n_beams, self.sonar.max_range, self.waypoint_scale)


def _segment_distance(ax: float, ay: float, bx: float, by: float, px: float, py: float) -> float:
    """Distance from point p to segment ab: the goal counts as reached if a step passes through it."""
    dx, dy = bx - ax, by - ay
    n2 = dx * dx + dy * dy
    s = 0.0 if n2 == 0 else min(1.0, max(0.0, ((px - ax) * dx + (py - ay) * dy) / n2))
    return math.hypot(ax + s * dx - px, ay + s * dy - py)


class Mission:
    """Follows a scenario's route decision by decision; call ``step(action)``, read ``waypoint()``."""

    def __init__(self, scenario: Scenario, config: EnvConfig):
        self.scenario, self.config = scenario, config
        self.world = scenario.world
        self.x, self.y, self.yaw = (float(v) for v in scenario.start)
        self.route = scenario.route()
        self.index = 0
        self.prev = np.array(scenario.start[:2], dtype=float)
        self.steps = 0
        self.t = 0.0
        self.outcome: str | None = None
        pts = np.vstack([self.prev, self.route])
        self.seg_lengths = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        self.route_length = float(self.seg_lengths.sum())
        self.max_steps = int(math.ceil(config.max_steps_factor * self.route_length)) + config.max_steps_extra
        self.travelled = 0.0
        self.track = [(self.x, self.y, self.yaw)]
        self._advance_waypoints()
        self.remaining = self.remaining_route()

    # --- geometry -----------------------------------------------------------------------
    def waypoint(self) -> tuple[float, float]:
        """Distance (m) and body-frame heading error (rad, left positive) to the current waypoint."""
        wx, wy = self.route[self.index]
        dx, dy = wx - self.x, wy - self.y
        return math.hypot(dx, dy), wrap_angle(math.atan2(dy, dx) - self.yaw)

    def remaining_route(self) -> float:
        wx, wy = self.route[self.index]
        return math.hypot(wx - self.x, wy - self.y) + float(self.seg_lengths[self.index + 1:].sum())

    def segment_offset(self) -> float:
        """Distance from the vehicle to the current route segment (prev waypoint -> waypoint)."""
        a, b = self.prev, self.route[self.index]
        ab = b - a
        n2 = float(ab @ ab)
        s = 0.0 if n2 == 0 else min(1.0, max(0.0, float((np.array([self.x, self.y]) - a) @ ab) / n2))
        return math.hypot(self.x - a[0] - s * ab[0], self.y - a[1] - s * ab[1])

    def _advance_waypoints(self) -> None:
        last = len(self.route) - 1
        while self.index < last:
            a, b = self.prev, self.route[self.index]
            ab = b - a
            n2 = float(ab @ ab)
            passed = n2 > 0 and float((np.array([self.x, self.y]) - a) @ ab) / n2 >= 1.0
            if math.hypot(b[0] - self.x, b[1] - self.y) < self.config.waypoint_radius or passed:
                self.prev = b.copy()
                self.index += 1
            else:
                break

    # --- dynamics -----------------------------------------------------------------------
    def step(self, action: float) -> tuple[float, str | None]:
        """Apply one decision; return (reward, outcome or None)."""
        cfg, rw = self.config, self.config.reward
        x0, y0 = self.x, self.y
        self.x, self.y, self.yaw = decision_step(self.x, self.y, self.yaw, float(action), cfg.vehicle,
                                                 self.world.current, cfg.motion)
        self.steps += 1
        self.t += cfg.vehicle.decision_period
        self.travelled += math.hypot(self.x - x0, self.y - y0)
        self.track.append((self.x, self.y, self.yaw))
        self._advance_waypoints()
        mid = (0.5 * (x0 + self.x), 0.5 * (y0 + self.y))
        clearance = min(self.world.clearance(self.x, self.y, self.t),
                        self.world.clearance(*mid, self.t - 0.5 * cfg.vehicle.decision_period))

        dist, err = self.waypoint()
        remaining = self.remaining_route()
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
        elif self.index == len(self.route) - 1 and _segment_distance(x0, y0, self.x, self.y,
                                                                     *self.route[-1]) < cfg.goal_radius:
            self.outcome, reward = "goal", reward + rw.goal
        elif self.segment_offset() > cfg.wander_distance:
            self.outcome, reward = "wander", reward + rw.wander
        elif self.steps >= self.max_steps:
            self.outcome = "timeout"
        return reward, self.outcome

    @property
    def pose(self) -> tuple[float, float, float]:
        return self.x, self.y, self.yaw

    def info(self) -> dict:
        return {"outcome": self.outcome, "steps": self.steps, "waypoint_index": self.index,
                "route_length": self.route_length, "travelled": self.travelled,
                "pose": (self.x, self.y, self.yaw), "time": self.t}

    def observe(self, ranges: np.ndarray) -> np.ndarray:
        d, e = self.waypoint()
        return self.config.layout.build(ranges, d, e)

    def scan(self, rng: np.random.Generator | None = None) -> np.ndarray:
        return self.config.sonar.scan(self.world, self.x, self.y, self.yaw, self.t, rng)
