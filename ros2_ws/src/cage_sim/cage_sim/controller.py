"""The classical reactive baseline: a dynamic-window (arc rollout) controller over the sonar.

It reads the same observation a learned policy reads (``observation.py``) and returns the same
action (Box[-1, 1], scaled to +-20 deg per decision by the vehicle model), so the env, the evaluator
and the policy node treat the two alike (``Policy`` protocol).

Why arcs: the vehicle cannot turn on the spot (turning radius ~2.9 m), so a direction that is open
as a straight ray can still be unreachable without hitting something on the way round. Each
candidate is a manoeuvre the vehicle can really fly (turn at a fixed action for some decisions, then
hold the heading; or hold the heading first, then turn: the way to pass through a goal that lies
inside the turning circle instead of orbiting it), rolled out with the same vehicle model in the
body frame; the sonar returns are the obstacle points. With a ``Perception`` (``decide``), the
rollouts carry the drift (velocity over ground minus through-water velocity, from the DVL) and
each return moves with its estimated velocity, so what is checked is what will be flown. The
candidate that keeps clear and comes nearest the waypoint wins; when the waypoint is the goal,
nothing after passing through it is checked (the mission ends there).

``pursuit`` adds one candidate that re-aims at the waypoint at every decision of its rollout. Why:
with the waypoint behind in a strong drift (a goal by the net, downstream in a 0.5 m/s current),
every turn held for the whole horizon is blown off it or into the net beside it, and "aim once,
then hold" turns only one step, so the controller put off the turn a decision at a time and flew
away from the goal. Off by default: the classical baseline, and residual policies trained on it,
stay as they were; a residual policy's file records it (``tunables``) and its shield's fallback is
built alike (``driver.fallback_for``). A residual policy retrained on it did no better in the cells
it was made for (README, session 35).

``handover`` (m, 0 = off) stops checking a candidate ``handover_tail`` decisions after it comes
that near an intermediate waypoint (not the goal): the route then hands over to the next waypoint
(``RouteTracker.waypoint_radius``, 2 m), so the rest of a straight rollout is never flown. Why: by
the net in a 0.5 m/s current, every candidate through such a waypoint drifts on into the net over
its 10 decisions, so the plain controller turned away from a waypoint 2 m off (and the goal just
beyond it) and flew a detour (session 38's cell-23 trace). The tail keeps a wall right behind the
waypoint in the check. Off by default, recorded by residual policies like ``pursuit``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from .observation import ObservationLayout
from .perception import Perception, body_drift
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
    goal_pass: float = 0.8          # m: a rollout point this near the goal counts as reaching it
    pursuit: bool = False           # one more candidate: re-aim at the waypoint at every decision
    handover: float = 0.0           # m: an intermediate waypoint this near counts as reached (0: off)
    handover_tail: int = 5          # decisions still checked after reaching it (2: 3x the collisions, session 39)
    remembered: str = "all"         # which remembered returns count (``returns``): one of REMEMBERED

    def __post_init__(self) -> None:
        if self.remembered not in REMEMBERED:
            raise ValueError(f"remembered: must be one of {', '.join(REMEMBERED)}, got {self.remembered!r}")
        self._beams = self.layout.angles if hasattr(self.layout, "angles") else \
            np.arange(self.layout.n_beams) * (2 * math.pi / self.layout.n_beams)
        self._first, self._traj = self._candidates()
        period = self.vehicle.decision_period
        self._times = np.repeat(np.arange(self.horizon) * period, 2) + np.tile([0.5 * period, period], self.horizon)
        self._reach = float(np.linalg.norm(self._traj, axis=-1).max()) + self.comfort
        # The candidates share their first decisions (hold a for k decisions: the same arc for every
        # k), so 800 of their 1380 (point, time) pairs are distinct: the clearance is computed once
        # for each distinct one and read back for every candidate (the same values, 40 % less work).
        self._distinct = DistinctPoints.of(self._traj, self._times)
        self._kept_bins = remembered_bins(self.layout, self.remembered)
        self._kept_angles = self.layout.memory_angles[self._kept_bins] if len(self._kept_bins) else np.zeros(0)

    def _candidates(self) -> tuple[np.ndarray, np.ndarray]:
        """Body-frame rollouts: hold action a for k decisions then fly straight, or fly straight for
        j decisions then hold a full turn (a, k, j enumerated)."""
        firsts, trajs = [0.0], [self._rollout(lambda h: 0.0)]
        for a in (-1.0, -0.6, -0.3, 0.3, 0.6, 1.0):
            for k in range(1, self.horizon + 1):
                firsts.append(a)
                trajs.append(self._rollout(lambda h, a=a, k=k: a if h < k else 0.0))
        for a in (-1.0, 1.0):
            for j in range(1, 5):
                firsts.append(0.0)
                trajs.append(self._rollout(lambda h, a=a, j=j: a if h >= j else 0.0))
        return np.array(firsts), np.array(trajs)

    def _rollout(self, action_at) -> np.ndarray:
        x = y = yaw = 0.0
        pts = []
        for h in range(self.horizon):
            x0, y0 = x, y
            x, y, yaw = decision_step(x, y, yaw, action_at(h), self.vehicle)
            pts += [(0.5 * (x0 + x), 0.5 * (y0 + y)), (x, y)]
        return np.array(pts)

    @property
    def reach(self) -> float:
        """m from the vehicle within which a return is kept (``returns``): as far as the rollouts fly,
        plus the comfort distance."""
        return self._reach

    @property
    def reads_memory(self) -> bool:
        """Whether ``returns`` reads any memory bin: the kept ones beside a scan, or the whole memory
        that stands for the scan (a layout without one)."""
        bins = int(getattr(self.layout, "memory_bins", 0) or 0)
        return bool(bins) and (not getattr(self.layout, "scan", True) or len(self._kept_bins) > 0)

    def returns(self, obs: np.ndarray, reach: float | None = None, memory: np.ndarray | None = None) -> np.ndarray:
        """Sonar returns within ``reach`` m (default: what the rollouts can come near), as body-frame
        points (K, 2): the obstacle points the manoeuvres are checked against. With a v2 layout that
        has a memory, the remembered returns (360 deg, e.g. beside and behind a forward-looking sonar)
        count too; with ``remembered`` "out_of_view" only those outside the scan's field of view.
        ``memory``: a memory histogram (m, the layout's bins) read in place of the observation's
        (with "cleared", the vehicle's memory without the returns it has since seen past or passed
        through: ``Driver.remembered_now``); without one the observation's is read."""
        remembered = None
        if getattr(self.layout, "memory_bins", 0):
            remembered = self.layout.memory_from(obs) if memory is None else np.asarray(memory, dtype=np.float64)
        scan = getattr(self.layout, "scan", True)
        ranges = self.layout.ranges_from(obs) if scan else remembered   # without a scan the memory stands for it
        ang = self._beams
        if scan and remembered is not None:
            ranges = np.concatenate([ranges, remembered[self._kept_bins]])
            ang = np.concatenate([ang, self._kept_angles])
        seen = ranges < min(self.layout.max_range * 0.999, reach or self._reach)
        return np.stack([ranges[seen] * np.cos(ang[seen]), ranges[seen] * np.sin(ang[seen])], axis=1)

    def perceive(self, obs: np.ndarray) -> Perception:
        """What an observation alone says: its returns as static points, and the drift when the
        layout carries the velocity over ground (v2 with ``velocity``)."""
        v = self.layout.velocity_from(obs) if hasattr(self.layout, "velocity_from") else None
        drift = body_drift(v, self.vehicle.speed) if v is not None else np.zeros(2)
        return Perception(self.returns(obs), drift=drift)

    def act_one(self, obs: np.ndarray) -> float:
        dist, err = self.layout.waypoint_from(obs)
        return self.decide(float(dist), float(err), self.perceive(obs))

    def decide(self, dist: float, err: float, p: Perception) -> float:
        """The action for a waypoint at (dist, err) (body frame) given what is perceived."""
        return self.choose(dist, err, p)[0]

    def choose(self, dist: float, err: float, p: Perception) -> tuple[float, bool]:
        """(``decide``'s action, whether the manoeuvre it starts passes through the goal: the
        waypoint is the goal and the rollout comes within ``goal_pass`` of it, clear all the way)."""
        plan = self._plan(dist, err, p.drift)
        return self._pick(plan, p.final, self._clear_along(plan, p.returns, p.relative()))

    def choose_twice(self, dist: float, err: float, p: Perception, extra: np.ndarray
                     ) -> tuple[tuple[float, bool], tuple[float, bool]]:
        """(``choose`` on ``p``, ``choose`` on ``p`` with the static points ``extra`` (M, 2, body
        frame: the known map, ``driver.with_map``) added to its returns), the returns' clearances
        computed once: the extra points' are computed alone and the lesser taken. Why: a residual
        policy's base reads the scan alone and the shield the scan and the map, and the clearance
        is most of a decision's cost (the map added 0.7 ms at p50 through ``policy_node``). The
        same decisions as two ``choose`` calls: a minimum over two groups of points is the minimum
        over all, and ``_clearance_below``'s values are exact below its cap in both."""
        plan = self._plan(dist, err, p.drift)
        clear = self._clear_along(plan, p.returns, p.relative())
        extra = np.asarray(extra, dtype=np.float64).reshape(-1, 2)
        rel = np.broadcast_to(np.asarray(p.drift, dtype=np.float64), extra.shape)   # static: drift - 0
        both = np.minimum(clear, self._clear_along(plan, extra, rel))
        return self._pick(plan, p.final, clear), self._pick(plan, p.final, both)

    def _plan(self, dist: float, err: float, drift) -> tuple:
        """What a decision's candidates are, before any return is read: (goal, drift, the aimed
        action, every candidate's rollout points and first action, the number of aimed ones)."""
        goal = np.array([dist * math.cos(err), dist * math.sin(err)])
        drift = np.asarray(drift, dtype=np.float64)
        # Aimed candidates, each starting by turning onto the waypoint (crabbing against the drift):
        # then hold that heading; with ``pursuit`` also: keep re-aiming at every decision.
        a_aim = float(np.clip(self._aim(err, drift) / self.vehicle.max_turn, -1.0, 1.0)) if dist > 0 else 0.0
        aims = [self._rollout(lambda h: a_aim if h == 0 else 0.0)]
        if self.pursuit:
            aims.append(self._pursuit(goal, drift))
        traj = np.concatenate([self._traj, np.stack(aims)])
        firsts = np.append(self._first, [a_aim] * len(aims))
        return goal, drift, a_aim, traj, firsts, len(aims)

    def _clear_along(self, plan: tuple, returns: np.ndarray, rel: np.ndarray) -> np.ndarray:
        """[cand, point] clearance from ``returns`` (relative drift ``rel``) along every candidate
        (exact below ``max(comfort, min_clearance)`` on the fixed candidates; inf with none near)."""
        _, drift, _, traj, _, n_aims = plan
        near = np.linalg.norm(returns, axis=1) < self._reach + np.hypot(*drift) * self._times[-1] \
            if len(returns) else np.zeros(0, dtype=bool)
        if not near.any():
            return np.full(traj.shape[:2], np.inf)
        # each return as seen from the vehicle drifting past it: q - (drift - u) t
        pts, rel = returns[near], rel[near]
        fixed = self._clearance_below(max(self.comfort, self.min_clearance), rel, pts)[self._distinct.inverse]
        aimed = nearest_distance(traj[-n_aims:], self._times[None, :], rel, pts)
        return np.concatenate([fixed.reshape(self._traj.shape[:2]), aimed])  # [cand, point]

    def _pick(self, plan: tuple, final: bool, clear_along: np.ndarray) -> tuple[float, bool]:
        """``choose``'s answer from the candidates' clearances."""
        goal, drift, a_aim, traj, firsts, n_aims = plan
        flown = traj + drift * self._times[None, :, None]                # [cand, point, 2] over ground
        to_goal = np.linalg.norm(flown - goal, axis=-1)                  # [cand, point]
        if final:   # the mission ends on passing through the goal: what comes after is never flown
            clear_along = np.where(_after(to_goal < self.goal_pass, 1), np.inf, clear_along)
        elif self.handover > 0:   # the route hands over to the next waypoint: the rest is not flown
            clear_along = np.where(_after(to_goal < self.handover, 1 + 2 * self.handover_tail), np.inf, clear_along)
        clearance = clear_along.min(axis=1)
        # Closest approach to the waypoint, counted only along the part flown before getting too close.
        blocked = np.cumsum(clear_along < self.min_clearance, axis=1) > 0
        to_goal = np.where(blocked, np.inf, to_goal)
        if final:
            progress = self._final_cost(to_goal, flown, goal)
        else:
            progress = to_goal.min(axis=1)
        score = progress + self.comfort_weight * np.maximum(0.0, self.comfort - clearance)
        ok = clearance >= self.min_clearance
        if not ok.any():
            return float(firsts[int(np.argmax(clearance))]), False   # boxed in: the manoeuvre that keeps farthest away
        through = final & (to_goal < self.goal_pass).any(axis=1)
        best = int(np.argmin(np.where(ok, score, np.inf)))
        aimed = ok[-n_aims:] & (score[-n_aims:] <= score[best] + 0.05)
        if aimed.any():           # flying at the waypoint is as good: do exactly that (no dithering)
            return a_aim, bool(through[-n_aims:][aimed].any())
        return float(firsts[best]), bool(through[best])

    def _clearance_below(self, cap: float, rel: np.ndarray, pts: np.ndarray) -> np.ndarray:
        """``nearest_distance`` at the distinct rollout points, exact where it is below ``cap`` and
        some value >= ``cap`` (inf) elsewhere. Why that is enough: ``decide`` reads a clearance only
        against ``min_clearance`` and ``comfort`` (the penalty is 0 beyond it), and the boxed-in
        choice compares clearances that all lie below ``min_clearance``. Why: about 5 % of the
        (point, return) pairs lie within ``comfort``; each return is paired only with the blocks of
        points whose bounding box, flown with the return's relative drift, comes within ``cap``."""
        return self._distinct.nearest_below(self._distinct.points, rel, pts, cap)

    def _final_cost(self, to_goal: np.ndarray, flown: np.ndarray, g: np.ndarray) -> np.ndarray:
        """Metres to the goal for each candidate: where it passes through the goal, the path flown so
        far; where it does not, the whole rollout plus a lower bound from its end (distance, plus
        the detour a goal inside the end pose's turning circle needs). Why: the closest approach
        alone makes circling a goal that lies inside the turning circle look best (orbiting)."""
        step = 0.5 * self.vehicle.step_length
        hit = to_goal < self.goal_pass
        first = np.where(hit.any(axis=1), hit.argmax(axis=1), -1)
        cost = (first + 1) * step
        end, end_d = flown[:, -1], to_goal[:, -1]
        heading = np.arctan2(*(flown[:, -1] - flown[:, -2])[:, ::-1].T)
        r = self.vehicle.turning_radius
        side = np.stack([-np.sin(heading), np.cos(heading)], axis=1)                # left normal
        inside = np.minimum(np.linalg.norm(end + r * side - g, axis=1),
                            np.linalg.norm(end - r * side - g, axis=1)) < r
        bearing = np.abs(np.angle(np.exp(1j * (np.arctan2(g[1] - end[:, 1], g[0] - end[:, 0]) - heading))))
        rest = np.where(np.isfinite(end_d), np.hypot(g[0] - end[:, 0], g[1] - end[:, 1]) + r * bearing
                        + np.where(inside, 2 * r, 0.0), np.inf)
        return np.where(first >= 0, cost, flown.shape[1] * step + rest)

    def _pursuit(self, goal: np.ndarray, drift: np.ndarray) -> np.ndarray:
        """Through-water body-frame rollout that re-aims at ``goal`` (over ground) at every decision,
        crabbing against ``drift``: what the controller flies when it keeps choosing to aim."""
        x = y = yaw = 0.0
        period, pts = self.vehicle.decision_period, []
        (dx, dy), (gx0, gy0) = (float(v) for v in drift), (float(v) for v in goal)   # plain floats: 10 steps
        for h in range(self.horizon):
            gx, gy = x + dx * h * period, y + dy * h * period                  # over ground now
            err = math.atan2(gy0 - gy, gx0 - gx) - yaw
            err = math.atan2(math.sin(err), math.cos(err))
            c, s = math.cos(yaw), math.sin(yaw)
            a = max(-1.0, min(1.0, self._aim(err, (c * dx + s * dy, -s * dx + c * dy)) / self.vehicle.max_turn))
            x0, y0 = x, y
            x, y, yaw = decision_step(x, y, yaw, a, self.vehicle)
            pts += [(0.5 * (x0 + x), 0.5 * (y0 + y)), (x, y)]
        return np.array(pts)

    def _aim(self, err: float, drift) -> float:
        """Heading change that makes the velocity over ground point at the waypoint (err without drift)."""
        cross = drift[0] * math.sin(err) - drift[1] * math.cos(err)       # drift x unit(goal direction)
        return err + math.asin(max(-1.0, min(1.0, cross / self.vehicle.speed)))

    def act(self, obs: np.ndarray) -> np.ndarray:
        return act_rows(self.act_one, obs)

    def tunables(self) -> dict[str, float]:
        """The controller's own parameters (not the layout or the vehicle): what a residual
        policy's file records, since its actions are moves of this controller's."""
        return {k: getattr(self, k) for k in ("horizon", "min_clearance", "comfort", "comfort_weight", "goal_pass",
                                              "pursuit", "handover", "handover_tail")}


REMEMBERED = ("all", "out_of_view", "cleared")


def remembered_bins(layout, remembered: str = "all") -> np.ndarray:
    """Indices of the memory bins whose returns ``ArcController.returns`` counts beside the scan:
    every one ("all"), or those that reach outside the scan's field of view ("out_of_view", and
    "cleared", which reads them from a memory without the returns since seen past or passed through:
    ``Driver.remembered_now``): a bin wholly inside the view is dropped; none is kept for a
    360 deg scan. A layout without a scan reads its memory as the scan: every bin.

    Why "out_of_view": the memory is there for what the sonar does not see now (beside and behind a
    forward-looking sonar), and a return remembered where the sonar looks again is one it no longer
    sees there: a fish school that has fled (schools flee at 0.8 m/s, so a 10 s memory holds a trail
    of them up to 8 m long), or a noisy range kept as the nearest of ten. With every bin, the
    `multibeam360` driver lost 19 and 26 goals of 2000 more in the two hardest sea cells than with
    none (docs/notes/sessions.md, session 52).

    Why "cleared": with "out_of_view", `fls`'s driver collided about twice as often (15 against 8 in
    cells 16-23 of the held-out seed). Its vehicle now entered the trail a fled school had left
    ahead of it, and once the trail lay beside and behind it, out of the sector, the shield met it
    again, remembered a few centimetres away: no manoeuvre looked safe, and the one it flew met a
    real square or the net (5 of the 11 collisions only "out_of_view" had there, session 53).
    Returns the sonar has since seen past, or the vehicle passed through, are no school and no wall."""
    bins = int(getattr(layout, "memory_bins", 0) or 0)
    if remembered == "all" or not bins or not getattr(layout, "scan", True):
        return np.arange(bins)
    half = 0.5 * float(layout.angle_increment)
    lo, hi = float(layout.angle_min) - half, float(layout.angle_min) + float(layout.fov) - half
    if hi - lo >= 2 * math.pi - 1e-9:
        return np.zeros(0, dtype=np.int64)
    width = 2 * math.pi / bins
    start = (np.arange(bins) * width - 0.5 * width - lo) % (2 * math.pi)   # a bin's first edge, past the sector's
    return np.flatnonzero(start + width > hi - lo + 1e-9)   # any part outside the sector: kept


def _after(reached: np.ndarray, lag: int) -> np.ndarray:
    """[cand, point] True from ``lag`` points after a candidate's first ``reached`` point on."""
    seen = np.cumsum(reached, axis=1) > 0
    lag = min(lag, seen.shape[1])
    return np.concatenate([np.zeros_like(seen[:, :lag]), seen[:, :-lag]], axis=1)


def act_rows(act_one, obs: np.ndarray) -> np.ndarray:
    """The Policy protocol's shapes for a per-observation rule: (D,) -> (1,), (B, D) -> (B, 1)."""
    obs = np.asarray(obs, dtype=np.float64)
    if obs.ndim == 1:
        return np.array([act_one(obs)], dtype=np.float32)
    return np.array([[act_one(o)] for o in obs], dtype=np.float32)


def nearest_distance(points: np.ndarray, times: np.ndarray, relative: np.ndarray, returns: np.ndarray) -> np.ndarray:
    """Distance from each point flown to its nearest return, each return seen from the drifting
    vehicle: ``points`` [..., 2] reached at ``times`` (broadcast to [...]), K ``returns`` [K, 2]
    with the vehicle's velocity ``relative`` to each [K, 2] -> [...]: min_k |p + t rel_k - q_k|.
    Why it is written this way (most of a decision's time with a memory's 100+ returns): the
    returns that share the first one's relative velocity (usually all the static ones: the drift)
    see the points shifted once, ``p + t rel`` made on [...] instead of on [..., K]; the others
    are shifted per return. Every element is the same operations in the same order as
    ``sqrt(min_k(dx * dx + dy * dy))`` with ``dx = p + t rel_k - q_k``, and a minimum over two
    groups is the minimum over all, so the result is bit-identical to that. Inf with no return.
    One function for the baseline's rollouts and the shield's."""
    times = np.asarray(times)
    if len(returns) == 0:
        return np.full(np.broadcast_shapes(points.shape[:-1], times.shape), np.inf)
    shared = (relative == relative[0]).all(axis=1)
    r = relative[0]
    best = _min_squared(points[..., 0] + times * r[0], points[..., 1] + times * r[1], returns[shared], 1)
    if not shared.all():
        t, rel = times[..., None], relative[~shared]
        best = np.minimum(best, _min_squared(points[..., 0, None] + t * rel[:, 0],
                                             points[..., 1, None] + t * rel[:, 1], returns[~shared], 0))
    return np.sqrt(best)


@dataclass(frozen=True)
class DistinctPoints:
    """Rollouts that share their first decisions, laid out so each distinct (point, time) pair is
    measured once: ``index`` [N] one flat position (into the rollouts' [C * P] points) of each,
    ``inverse`` [C * P] which distinct pair each point is, ``points`` [N, 2] and ``times`` [N]
    the pairs, ``blocks`` their ``point_blocks``. Why: held turns of k and k + 1 decisions fly the
    same first k (the controller's 1380 points are 800 pairs; the shield's 165 continuations of 18
    points, S-turns included, are 1530); and a rigid move of all the points (the shield's
    continuations flown from the first decision's end) keeps each block a block."""

    points: np.ndarray
    times: np.ndarray
    index: np.ndarray
    inverse: np.ndarray
    blocks: np.ndarray

    @classmethod
    def of(cls, traj: np.ndarray, times: np.ndarray) -> "DistinctPoints":
        """``traj`` [C, P, 2] rollouts whose point p is flown at ``times[p]``."""
        when = np.broadcast_to(np.asarray(times)[None, :], traj.shape[:2])
        key = np.concatenate([traj.reshape(-1, 2), when.reshape(-1, 1)], axis=1)
        distinct, index, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
        points, t = distinct[:, :2], distinct[:, 2]
        return cls(points, t, index, inverse.reshape(-1), point_blocks(points, t))

    def nearest_below(self, points: np.ndarray, relative: np.ndarray, returns: np.ndarray, cap: float) -> np.ndarray:
        """[N] ``nearest_distance`` at ``points`` (these pairs' points, or the same moved rigidly;
        flown at ``times``), exact where it is below ``cap``, some value >= ``cap`` (inf) elsewhere
        (``_min_squared_near``)."""
        return np.sqrt(_min_squared_near(points, self.times, self.blocks, relative, returns, cap))


def point_blocks(points: np.ndarray, times: np.ndarray, size: int = 8) -> np.ndarray:
    """[B, size] indices of ``points`` in blocks of neighbours flown at the same time (sorted by
    bearing at each time; the last block of a time padded with its last index): points that a
    uniform shift ``t * r`` moves together, so a block's bounding box bounds all of its points."""
    blocks = []
    for t in np.unique(times):
        idx = np.flatnonzero(times == t)
        idx = idx[np.argsort(np.arctan2(points[idx, 1], points[idx, 0]), kind="stable")]
        pad = -len(idx) % size
        blocks.append(np.concatenate([idx, np.repeat(idx[-1:], pad)]).reshape(-1, size))
    return np.concatenate(blocks)


def _min_squared_near(points: np.ndarray, times: np.ndarray, blocks: np.ndarray, relative: np.ndarray,
                      returns: np.ndarray, cap: float) -> np.ndarray:
    """(N,) ``nearest_distance(points, times, relative, returns) ** 2`` where it is below
    ``cap ** 2``, inf where no return comes within ``cap`` of a point's block (``point_blocks``).
    Each pair is the same operations as in ``nearest_distance`` (``dx = p + t rel_k - q_k``,
    squared, plus ``dy``'s), and a minimum does not depend on the order, so the values kept are
    bit-identical. A block's points share one time, so the box of ``p + t rel_k`` over the block
    is its box of ``p`` moved by ``t rel_k`` (rounding is monotonic: no point falls outside)."""
    best = np.full(len(points), np.inf)
    if len(returns) == 0:
        return best
    t = times[blocks[:, 0]]                                                          # [B]
    bx, by = points[blocks, 0], points[blocks, 1]                                    # [B, size]
    sx, sy = t[:, None] * relative[:, 0], t[:, None] * relative[:, 1]                # [B, K] shift
    qx, qy = returns[:, 0], returns[:, 1]
    gx = np.maximum(np.maximum((bx.min(axis=1)[:, None] + sx) - qx, qx - (bx.max(axis=1)[:, None] + sx)), 0.0)
    gy = np.maximum(np.maximum((by.min(axis=1)[:, None] + sy) - qy, qy - (by.max(axis=1)[:, None] + sy)), 0.0)
    b, k = np.nonzero(gx * gx + gy * gy < cap * cap * (1 + 1e-9))
    if len(b) == 0:
        return best
    idx = blocks[b]                                                                  # [M, size]
    dx = points[idx, 0] + sx[b, k][:, None] - qx[k, None]
    np.square(dx, out=dx)
    dy = points[idx, 1] + sy[b, k][:, None] - qy[k, None]
    np.square(dy, out=dy)
    dx += dy
    np.minimum.at(best, idx.ravel(), dx.ravel())
    return best


def _min_squared(x: np.ndarray, y: np.ndarray, returns: np.ndarray, per_point: int) -> np.ndarray:
    """min_k (x - qx_k)^2 + (y - qy_k)^2 over ``returns`` [K, 2]; ``x``, ``y`` are [...] when
    ``per_point`` (one shift for all returns) else [..., K]. The [..., K] arrays are made once per
    coordinate and worked in place (about twice as fast as fresh temporaries)."""
    if per_point:
        x, y = x[..., None], y[..., None]
    dx = x - returns[:, 0]
    np.square(dx, out=dx)
    dy = y - returns[:, 1]
    np.square(dy, out=dy)
    dx += dy
    return dx.min(axis=-1, initial=np.inf)
