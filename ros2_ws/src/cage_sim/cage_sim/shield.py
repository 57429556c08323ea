"""A safety shield for any policy: keep its action unless no safe manoeuvre can follow it.

Why: a learned policy sees one scan at a time and small obstacles between beams appear late; a
vehicle that turns no tighter than 2.9 m cannot always undo a bad decision. The shield asks, for the
policy's action, whether some manoeuvre the vehicle can really fly afterwards (hold an action for k
decisions, then straight; the same rollouts as the classical controller) keeps ``min_clearance``
from every sonar return over the next ``horizon`` decisions. If one does, the action stands. If not,
the action nearest to the policy's that has such a continuation replaces it, and when no action has
one, the classical controller's most open manoeuvre does. In open water (no return within reach)
the classical controller flies: straight at the waypoint, through the goal. Pure NumPy and deterministic, so the node
graph and the offline evaluator shield alike; ``interventions`` counts the overrides.

With a ``Perception`` (``decide``: drift from the DVL, returns moving with their estimated velocity,
``cage_sim.perception``) the manoeuvres are checked where they will really be flown: a 0.25 m/s
current moves the vehicle 1.25 m over the 5-decision horizon, more than the margin a still-water
check leaves. ``act`` (observation only) checks in still water against static returns.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .controller import ArcController, Policy, act_rows
from .perception import Perception
from .vehicle import decision_step


@dataclass
class SafetyShield:
    policy: Policy
    fallback: ArcController = field(default_factory=ArcController)
    horizon: int = 5                 # decisions checked: the first one plus horizon-1 of continuation
    min_clearance: float = 1.0       # m from every sonar return along the whole manoeuvre
    n_actions: int = 21              # alternative first actions tried when the policy's is unsafe
    open_water: bool = True          # with no return in reach, fly the classical controller's action
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

    def safe(self, firsts: np.ndarray, returns: np.ndarray, relative: np.ndarray | None = None,
             goal: np.ndarray | None = None, drift: np.ndarray | None = None) -> np.ndarray:
        """For each first action: does some continuation keep min_clearance from all returns?

        ``relative``: (K, 2) drift of the vehicle relative to each return (``Perception.relative``),
        m/s in the body frame; None = still water and static returns. ``goal`` (body frame, the
        mission's final waypoint) with ``drift``: nothing after passing through the goal is checked,
        since the mission ends there (a goal 2.5 m from the net is reachable head-on)."""
        period = self.fallback.vehicle.decision_period
        t_first = np.array([0.5, 1.0]) * period
        t_cont = period + np.tile([0.5, 1.0], self.horizon - 1) * period + \
            np.repeat(np.arange(self.horizon - 1), 2) * period
        rel = np.zeros_like(returns) if relative is None else np.asarray(relative, dtype=np.float64)
        dr = np.zeros(2) if drift is None else np.asarray(drift, dtype=np.float64)
        reach = self.fallback.goal_pass
        out = np.empty(len(firsts), dtype=bool)
        for i, a in enumerate(firsts):
            x1, y1, yaw1 = decision_step(0.0, 0.0, 0.0, float(a), self.fallback.vehicle)
            c, s = math.cos(yaw1), math.sin(yaw1)
            cont0 = self._cont @ np.array([[c, s], [-s, c]]) + (x1, y1)              # [C, P, 2]
            first0 = np.array([(0.5 * x1, 0.5 * y1), (x1, y1)])                      # chord points
            first = first0[:, None] + t_first[:, None, None] * rel[None]             # [2, K, 2]
            cont = cont0[:, :, None] + t_cont[None, :, None, None] * rel[None, None]  # [C, P, K, 2]
            d_first = np.linalg.norm(first - returns[None], axis=-1).min(axis=1)     # [2]
            d_cont = np.linalg.norm(cont - returns[None, None], axis=-1).min(axis=2)  # [C, P]
            if goal is not None:
                hit_first = np.linalg.norm(first0 + t_first[:, None] * dr - goal, axis=1) < reach
                if hit_first.any():
                    j = int(np.argmax(hit_first))
                    out[i] = bool(d_first[: j + 1].min() >= self.min_clearance)
                    continue
                hit = np.cumsum(np.linalg.norm(cont0 + t_cont[None, :, None] * dr - goal, axis=-1) < reach, axis=1)
                d_cont = np.where(np.concatenate([np.zeros_like(hit[:, :1]), hit[:, :-1]], axis=1) > 0, np.inf, d_cont)
            out[i] = d_first.min() >= self.min_clearance and bool((d_cont.min(axis=1) >= self.min_clearance).any())
        return out

    def act_one(self, obs: np.ndarray) -> float:
        dist, err = self.fallback.layout.waypoint_from(obs)
        return self.decide(obs, float(dist), float(err), self.fallback.perceive(obs))

    def decide(self, obs: np.ndarray, dist: float, err: float, p: Perception) -> float:
        """The policy's action for ``obs``, or the nearest safe one given what is perceived."""
        return self.check(float(np.asarray(self.policy.act(obs), dtype=np.float64).reshape(-1)[0]), dist, err, p)

    def check(self, action: float, dist: float, err: float, p: Perception) -> float:
        """``action`` (the policy's, already computed) if it is safe, else the nearest safe one.

        Open water (no return within the classical controller's reach, ~12 m): the controller's
        action, i.e. fly at the waypoint (crabbing against the drift) or through the goal. Nothing
        there gives a reason to turn away, and a policy that rarely saw an empty scan in training may
        (the shipped study policy turned hard left with the waypoint dead ahead), or may circle a goal."""
        a = float(np.clip(action, -1.0, 1.0))
        self.decisions += 1
        if self.open_water and len(p.returns) == 0:
            b = self.fallback.decide(dist, err, p)
            self.interventions += int(abs(b - a) > 0.05)
            return b
        drift_reach = float(np.abs(p.relative()).max(initial=0.0)) * self.horizon * \
            self.fallback.vehicle.decision_period if len(p.returns) else 0.0
        near = np.linalg.norm(p.returns, axis=1) < self._reach + drift_reach if len(p.returns) else \
            np.zeros(0, dtype=bool)
        returns, rel = p.returns[near], p.relative()[near]
        goal = np.array([dist * math.cos(err), dist * math.sin(err)]) if p.final else None
        if len(returns) == 0 or self.safe(np.array([a]), returns, rel, goal, p.drift)[0]:
            return a
        self.interventions += 1
        ok = self.safe(self._alternatives, returns, rel, goal, p.drift)
        if ok.any():
            return float(self._alternatives[ok][np.argmin(np.abs(self._alternatives[ok] - a))])
        return self.fallback.decide(dist, err, p)

    def act(self, obs: np.ndarray) -> np.ndarray:
        return act_rows(self.act_one, obs)
