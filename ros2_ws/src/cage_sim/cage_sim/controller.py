"""The classical reactive baseline: a dynamic-window (arc rollout) controller over the sonar.

It reads the same observation a learned policy reads (``observation.py``) and returns the same
action (Box[-1, 1], scaled to +-20 deg per decision by the vehicle model), so the env, the evaluator
and the policy node treat the two alike (``Policy`` protocol).

Why arcs: the vehicle cannot turn on the spot (turning radius ~2.9 m), so a direction that is open
as a straight ray can still be unreachable without hitting something on the way round. Each
candidate is a manoeuvre the vehicle can really fly (turn at a fixed action for some decisions, then
hold the heading), rolled out with the same vehicle model in the body frame; the sonar returns are
the obstacle points. The candidate that keeps clear and ends nearest the waypoint wins.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from .observation import ObservationLayout
from .vehicle import VehicleParams, decision_step


class Policy(Protocol):
    """What drives the vehicle: observation(s) (D,) or (B, D) -> action(s) (1,) or (B, 1) in [-1, 1]."""

    def act(self, obs: np.ndarray) -> np.ndarray: ...


@dataclass
class ArcController:
    layout: ObservationLayout = field(default_factory=ObservationLayout)
    vehicle: VehicleParams = field(default_factory=VehicleParams)
    horizon: int = 10               # decisions rolled out per candidate
    min_clearance: float = 1.1      # m: candidates passing closer to a return are rejected
    comfort: float = 2.5            # m: clearance below this is penalised
    comfort_weight: float = 2.0

    def __post_init__(self) -> None:
        self._beams = self.layout.angles if hasattr(self.layout, "angles") else \
            np.arange(self.layout.n_beams) * (2 * math.pi / self.layout.n_beams)
        self._first, self._traj = self._candidates()
        self._reach = float(np.linalg.norm(self._traj, axis=-1).max()) + self.comfort

    def _candidates(self) -> tuple[np.ndarray, np.ndarray]:
        """Body-frame rollouts: hold action a for k decisions, then fly straight (a, k enumerated)."""
        firsts, trajs = [0.0], [self._rollout(0.0, 0)]
        for a in (-1.0, -0.6, -0.3, 0.3, 0.6, 1.0):
            for k in range(1, self.horizon + 1):
                firsts.append(a)
                trajs.append(self._rollout(a, k))
        return np.array(firsts), np.array(trajs)

    def _rollout(self, a: float, k: int) -> np.ndarray:
        x = y = yaw = 0.0
        pts = []
        for h in range(self.horizon):
            x0, y0 = x, y
            x, y, yaw = decision_step(x, y, yaw, a if h < k else 0.0, self.vehicle)
            pts += [(0.5 * (x0 + x), 0.5 * (y0 + y)), (x, y)]
        return np.array(pts)

    def returns(self, obs: np.ndarray, reach: float | None = None) -> np.ndarray:
        """Sonar returns within ``reach`` m (default: what the rollouts can come near), as body-frame
        points (K, 2): the obstacle points the manoeuvres are checked against."""
        ranges = self.layout.ranges_from(obs)
        seen = ranges < min(self.layout.max_range * 0.999, reach or self._reach)
        ang = self._beams[seen]
        return np.stack([ranges[seen] * np.cos(ang), ranges[seen] * np.sin(ang)], axis=1)

    def act_one(self, obs: np.ndarray) -> float:
        dist, err = self.layout.waypoint_from(obs)
        goal = np.array([dist * math.cos(err), dist * math.sin(err)])
        pts = self.returns(obs)
        if len(pts):
            d = np.linalg.norm(self._traj[:, :, None, :] - pts[None, None, :, :], axis=-1)
            clear_along = d.min(axis=2)                                  # [cand, point on traj]
            clearance = clear_along.min(axis=1)
        else:
            clear_along = np.full(self._traj.shape[:2], np.inf)
            clearance = np.full(len(self._traj), np.inf)
        to_goal = np.linalg.norm(self._traj - goal, axis=-1)            # [cand, point]
        # Closest approach to the waypoint, counted only along the part flown before getting too close.
        blocked = clear_along < self.min_clearance
        to_goal = np.where(np.cumsum(blocked, axis=1) > 0, np.inf, to_goal)
        score = to_goal.min(axis=1) + self.comfort_weight * np.maximum(0.0, self.comfort - clearance)
        ok = clearance >= self.min_clearance
        if ok.any():
            best = int(np.argmin(np.where(ok, score, np.inf)))
        else:
            best = int(np.argmax(clearance))     # boxed in: the manoeuvre that keeps farthest away
        if best == 0 or (ok[0] and abs(err) < self.vehicle.max_turn and score[0] <= score[best] + 0.05):
            # Straight ahead is as good: steer exactly onto the waypoint bearing when it is open.
            return float(np.clip(err / self.vehicle.max_turn, -1, 1)) if ok[0] and dist > 0 else 0.0
        return float(self._first[best])

    def act(self, obs: np.ndarray) -> np.ndarray:
        return act_rows(self.act_one, obs)


def act_rows(act_one, obs: np.ndarray) -> np.ndarray:
    """The Policy protocol's shapes for a per-observation rule: (D,) -> (1,), (B, D) -> (B, 1)."""
    obs = np.asarray(obs, dtype=np.float64)
    if obs.ndim == 1:
        return np.array([act_one(obs)], dtype=np.float32)
    return np.array([[act_one(o)] for o in obs], dtype=np.float32)
