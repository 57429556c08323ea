"""A safety shield for any policy: keep its action unless no safe manoeuvre can follow it.

Why: a learned policy sees one scan at a time and small obstacles between beams appear late; a
vehicle that turns no tighter than 2.9 m cannot always undo a bad decision. The shield asks, for the
policy's action, whether some manoeuvre the vehicle can really fly afterwards (hold an action for k
decisions, then straight; the same rollouts as the classical controller) keeps ``min_clearance``
from every sonar return over the next ``horizon`` decisions. If one does, the action stands. If not,
the action nearest to the policy's that has such a continuation replaces it, and when no action has
one, the classical controller's most open manoeuvre does. Pure NumPy and deterministic, so the node
graph and the offline evaluator shield alike; ``interventions`` counts the overrides.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .controller import ArcController, Policy, act_rows
from .vehicle import decision_step


@dataclass
class SafetyShield:
    policy: Policy
    fallback: ArcController = field(default_factory=ArcController)
    horizon: int = 5                 # decisions checked: the first one plus horizon-1 of continuation
    min_clearance: float = 1.0       # m from every sonar return along the whole manoeuvre
    n_actions: int = 21              # alternative first actions tried when the policy's is unsafe
    decisions: int = 0
    interventions: int = 0

    def __post_init__(self) -> None:
        v = self.fallback.vehicle
        self._alternatives = np.linspace(-1.0, 1.0, self.n_actions)
        conts = [self._points(lambda h: 0.0, self.horizon - 1)]
        for b in (-1.0, -0.5, 0.5, 1.0):
            for k in range(1, self.horizon):
                conts.append(self._points(lambda h, b=b, k=k: b if h < k else 0.0, self.horizon - 1))
        self._cont = np.array(conts)                                   # [C, P, 2], from the origin
        self._reach = v.step_length * self.horizon + self.min_clearance + 0.5

    def _points(self, action_at, n: int) -> np.ndarray:
        """Mid and end points of ``n`` decisions flown from the origin with action_at(h)."""
        x = y = yaw = 0.0
        pts = []
        for h in range(n):
            x0, y0 = x, y
            x, y, yaw = decision_step(x, y, yaw, action_at(h), self.fallback.vehicle)
            pts += [(0.5 * (x0 + x), 0.5 * (y0 + y)), (x, y)]
        return np.array(pts).reshape(-1, 2)

    def safe(self, firsts: np.ndarray, returns: np.ndarray) -> np.ndarray:
        """For each first action: does some continuation keep min_clearance from all returns?"""
        out = np.empty(len(firsts), dtype=bool)
        for i, a in enumerate(firsts):
            x1, y1, yaw1 = decision_step(0.0, 0.0, 0.0, float(a), self.fallback.vehicle)
            c, s = math.cos(yaw1), math.sin(yaw1)
            cont = self._cont @ np.array([[c, s], [-s, c]]) + (x1, y1)               # [C, P, 2]
            first = np.array([(0.5 * x1, 0.5 * y1), (x1, y1)])                       # chord points
            d_first = np.linalg.norm(first[:, None] - returns[None], axis=-1).min()
            d_cont = np.linalg.norm(cont[:, :, None] - returns[None, None], axis=-1).min(axis=(1, 2))
            out[i] = d_first >= self.min_clearance and bool((d_cont >= self.min_clearance).any())
        return out

    def act_one(self, obs: np.ndarray) -> float:
        a = float(np.clip(np.asarray(self.policy.act(obs), dtype=np.float64).reshape(-1)[0], -1.0, 1.0))
        self.decisions += 1
        returns = self.fallback.returns(obs, self._reach)
        if len(returns) == 0 or self.safe(np.array([a]), returns)[0]:
            return a
        self.interventions += 1
        ok = self.safe(self._alternatives, returns)
        if ok.any():
            return float(self._alternatives[ok][np.argmin(np.abs(self._alternatives[ok] - a))])
        return self.fallback.act_one(obs)

    def act(self, obs: np.ndarray) -> np.ndarray:
        return act_rows(self.act_one, obs)
