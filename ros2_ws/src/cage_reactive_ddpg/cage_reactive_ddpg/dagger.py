"""DAgger rollouts: a student policy flies, the shielded driver says what it would have done.

Why: the learned policy alone collides where the shielded driver does not (the shield rolls out
manoeuvres with the drift and the returns' motion and replaces unsafe actions). Imitating the
driver's actions on the driver's own missions (behaviour cloning) is not enough: the student's
small errors lead it into states the driver never visits, and nobody tells it what to do there.
DAgger (Ross, Gordon & Bagnell 2011) rolls out the student, lets the teacher label every state the
student visits, and trains on all labels gathered so far.

The teacher is the whole shielded driver of ``cage_sim.driver`` (learned policy + shield with its
perception: drift from the DVL, returns' motion across scans, the manoeuvre in hand, the stall
watch), kept per mission along the student's track, so the labels are the actions the graph's
``policy_node`` would send in that state. The decisions are ``decide_batch``'s: the same code path
as ``evaluate`` and the node.

Pure NumPy (no torch, no ROS): it runs in worker processes (``distill``) that never import torch.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from cage_sim.controller import ArcController
from cage_sim.driver import Driver, decide_batch, mission_moment
from cage_sim.mission import EnvConfig, Mission, observe_batch
from cage_sim.route import ReplanWatch
from cage_sim.shield import SafetyShield

from .evaluate import replan_if_asked, replan_planner, run_missions, summarize
from .inference import NumpyActor
from .missions import episode_scenarios, waypoint_fn
from .policy import env_config_for, load_policy

OVERRIDE = 0.05     # |label - teacher's own action| above this: the shield (or a guard) changed it
# Why the label is what it is (``Labelled.kind``): the policy's own action, a safety override, the
# controller flying a stalled policy, the goal-orbit guard's approach, the controller in open water.
KINDS = ("own", "safety", "recovery", "approach", "open_water")


class StudentPolicy:
    """A student's weights (an ``Actor`` state dict as NumPy arrays) behind the ``Policy`` protocol."""

    def __init__(self, state: dict[str, np.ndarray]):
        self.actor = NumpyActor(state)

    def act(self, obs: np.ndarray) -> np.ndarray:
        return self.actor(np.asarray(obs, dtype=np.float32))


@dataclass
class Labelled:
    """What one batch of rollouts gathered: every state the flying policy met, with the teacher's label."""

    obs: np.ndarray            # (N, D) float32 observations
    label: np.ndarray          # (N,) the shielded driver's action there
    own: np.ndarray            # (N,) the teacher policy's own action (label != own: an override)
    kind: np.ndarray           # (N,) index into KINDS: why the label is what it is
    outcomes: dict[str, int] = field(default_factory=dict)   # how the flown missions ended

    @property
    def overridden(self) -> np.ndarray:
        return np.abs(self.label - self.own) > OVERRIDE

    @staticmethod
    def join(parts: "list[Labelled]") -> "Labelled":
        outcomes: dict[str, int] = {}
        for p in parts:
            for k, v in p.outcomes.items():
                outcomes[k] = outcomes.get(k, 0) + v
        return Labelled(*(np.concatenate([getattr(p, k) for p in parts]) for k in ("obs", "label", "own", "kind")),
                        outcomes)

    def counts(self) -> dict[str, int]:
        """States per kind of label."""
        return {k: int(np.sum(self.kind == i)) for i, k in enumerate(KINDS)}


@lru_cache(maxsize=4)
def teacher(path: str) -> tuple[SafetyShield, EnvConfig]:
    """The shielded driver around the policy file ``path`` and the EnvConfig it was trained with
    (one per worker process: the shield's rollout tables are built once)."""
    pol = load_policy(path)
    return SafetyShield(pol, ArcController(pol.layout)), env_config_for(pol.metadata)


@lru_cache(maxsize=4)
def _routes(planner: str):
    return waypoint_fn(planner)


def collect(teacher_path: str, student: dict[str, np.ndarray] | None, spec: str, seed: int, start: int, n: int,
            beta: float, noise_std: float, planner: str = "rrt", replan: bool = True) -> Labelled:
    """Fly missions ``start .. start+n-1`` of ``spec`` (seed ``seed``) and label every decision.

    Each decision is flown by the teacher (its label) with probability ``beta``, else by the student
    plus Gaussian noise of ``noise_std`` (clipped; a wider spread of states around the student's
    own, as in DART, Laskey et al. 2017); ``student`` None flies the teacher throughout. Replans under
    way as the graph does (``replan``). Deterministic for given arguments."""
    shield, env = teacher(teacher_path)
    routes = _routes(planner)
    scs = episode_scenarios(spec, n, seed, routes, start=start)
    pupil = StudentPolicy(student) if student is not None else None
    rng = np.random.default_rng([seed, start, 1])
    ms = [Mission(sc, env) for sc in scs]
    drivers = [Driver(shield, env.layout, env.vehicle, m.builder) for m in ms]
    planner_fn = replan_planner(routes, replan)
    watches = [ReplanWatch.defaults() for _ in ms] if planner_fn is not None else None
    obs_parts, labels, owns, kinds = [], [], [], []
    outcomes: dict[str, int] = {}
    live = list(range(len(ms)))
    while live:
        obs = observe_batch(env, [ms[i] for i in live], rng)
        label, kind = _label(shield, [drivers[i] for i in live], obs, [ms[i] for i in live])
        own = np.asarray(shield.policy.act(obs), dtype=np.float64).reshape(len(live), -1)[:, 0]
        flown = label
        if pupil is not None:
            mine = pupil.act(obs)[:, 0] + noise_std * rng.standard_normal(len(live))
            flown = np.where(rng.random(len(live)) < beta, label, np.clip(mine, -1.0, 1.0))
        obs_parts.append(obs.astype(np.float32))
        labels.append(label.astype(np.float32))
        owns.append(own.astype(np.float32))
        kinds.append(kind)
        still = []
        for i, a in zip(live, flown):
            _, outcome = ms[i].step(float(a))
            if outcome is None:
                still.append(i)
                if watches is not None:
                    replan_if_asked(ms[i], watches[i], planner_fn)
            else:
                outcomes[outcome] = outcomes.get(outcome, 0) + 1
        live = still
    return Labelled(np.concatenate(obs_parts), np.concatenate(labels), np.concatenate(owns),
                    np.concatenate(kinds), outcomes)


def _label(shield: SafetyShield, drivers: list[Driver], obs: np.ndarray, ms: list[Mission]) -> tuple[np.ndarray, np.ndarray]:
    """The shielded driver's action for each vehicle and why (``KINDS``), one decision at a time
    so that the shield's counters tell which of its rules chose it."""
    label, kind = np.empty(len(drivers)), np.zeros(len(drivers), dtype=np.int8)
    for j, (d, o, m) in enumerate(zip(drivers, obs, ms)):
        before = (shield.interventions, shield.recoveries, shield.approaches)
        a, _ = decide_batch([d], o[None], [mission_moment(m)])
        label[j] = a[0]
        if shield.recoveries > before[1]:
            kind[j] = 2
        elif shield.approaches > before[2]:
            kind[j] = 3
        elif shield.interventions > before[0]:
            kind[j] = 4 if len(shield.fallback.returns(o)) == 0 else 1
    return label, kind


def evaluate_student(teacher_path: str, student: dict[str, np.ndarray], spec: str, seed: int, start: int,
                     n: int, planner: str = "rrt", replan: bool = True) -> dict[str, int]:
    """Outcome counts of the student alone (raw, no shield) on missions ``start .. start+n-1``."""
    _, env = teacher(teacher_path)
    routes = _routes(planner)
    scs = episode_scenarios(spec, n, seed, routes, start=start)
    res = run_missions(StudentPolicy(student), scs, env, replan=replan_planner(routes, replan))
    return summarize(res)["counts"]
