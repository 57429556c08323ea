"""A safety shield for any policy: keep its action unless no safe manoeuvre can follow it.

Why: a learned policy sees one scan at a time and small obstacles between beams appear late; a
vehicle that turns no tighter than 2.9 m cannot always undo a bad decision. The shield asks, for the
policy's action, whether some manoeuvre the vehicle can really fly afterwards (hold an action for k
decisions, then straight; the same rollouts as the classical controller) keeps ``min_clearance``
from every sonar return over the look-ahead. If one does, the action stands. If not, the action
nearest to the policy's that has such a continuation replaces it. In open water (no return within
reach) the classical controller flies: straight at the waypoint, through the goal. Pure NumPy and
deterministic, so the node graph and the offline evaluator shield alike; ``interventions`` counts
the overrides.

The look-ahead is 5 decisions in still water and grows with the drift (``horizon_for``: 10 at
0.5 m/s). Why: a current keeps pushing while the vehicle turns away (a half turn takes 9 s, 4.5 m at
0.5 m/s), so a state that looks safe for 5 decisions can already be one no turn escapes; measured on
the sea_small matrix this halved the shield's collisions at 0.5 m/s (1.2 -> 0.5 %). When no action
is safe over the whole look-ahead, the shield takes the longest look-ahead some action survives
and, among those actions, the one that keeps farthest from the returns over the whole of it.

Near the goal the shield also guards against orbiting (``approach``): a policy action that turns
toward a goal no held turn that way can reach (``orbits_goal``: the goal lies inside the full-turn
circle on that side) is replaced by the classical controller's approach (fly on, then turn back through
the goal), which is then checked like any other action. Why: the learned policies turn as hard as
they may at a goal beside them and circled it until timeout (1-2 % of fls missions in still water).
In a current the circle drifts on and does not orbit, so the guard stays out of it there.

An override carries on (``Commitment``, one per vehicle): when the policy's action is unsafe again
at the next decision, the next action of the manoeuvre that proved the last override safe is tried
first, so the shield keeps turning away the way it began instead of swinging between a left and a
right escape (and flying straight on between them into the net).

A policy that makes no progress along its route for 15 decisions (``check(..., stalled=True)``, told
by the vehicle's ``route.StallWatch`` in ``driver``) is handed to the classical controller until the
vehicle is 5 m further along than it ever was (or for 30 decisions); the controller's actions are
checked like the policy's. Why: the learned policies sometimes loop, safely, among obstacles near a
waypoint until timeout, and a new plan puts them back in the same place.

With a ``Perception`` (``decide``: drift from the DVL, returns moving with their estimated velocity,
``cage_sim.perception``) the manoeuvres are checked where they will really be flown: a 0.25 m/s
current moves the vehicle 1.25 m over 5 decisions, more than the margin a still-water check
leaves. ``act`` (observation only) checks in still water against static returns.

The returns are the sonar's and, since session 45, the known map's (``cage_sim.map_points``, added
by ``driver.with_map``: the known obstacles' outlines and the nominal net circle), so a face the
sonar has not swept yet is kept clear of too; the shield itself does not tell them apart.

Two additions of session 42 (``s_turns``, ``sure_approach``; on by default, either can be turned
off; measured in ``docs/notes/sessions.md``: in the two hardest sea cells they turn 9 misses into
goals and 3 goals into misses; over the whole 24-cell matrix the gain is within the noise):
- ``s_turns``: when no held turn keeps the margin (boxed in), two-phase continuations are tried
  too (hold b1 for k decisions, then another turn b2: ``s_turn_manoeuvres``), and the boxed-in
  choice weighs them. Why: in a current onto two obstacles the only way out can be a gentle turn
  one way and then a full turn the other (the only survivors of cell 19 mission 911 of the sea
  matrix, which held turns left to collide).
- ``sure_approach``: terminal guidance. With the goal in the controller's reach, a manoeuvre of
  the controller's that passes through it (``ArcController.choose``) replaces the policy's action
  (then checked like any other). Why: the learned policies sometimes turn hard at a goal 1-2 m off
  and miss it in a current, which then carries the vehicle away (cell 23 mission 440: 1.2 m off,
  then a timeout). The cost: the controller flies the last metres of most missions (a fifth of
  all decisions of ``cage``, with the same outcomes there). A version that let the policy fly
  until no continuation of its action passed through the goal gained nothing over the sea matrix
  (23,916 goals against 23,915 without either rule; this one: 23,921).

Session 43 adds ``goal_search`` (on by default): when the controller has no manoeuvre through the
goal in reach, every alternative first action followed by every continuation of ``goal_horizon``
(15) decisions, held turns and S-turns, is tried for one that passes through the goal clear of
the returns, and the soonest flies (``through_goal``). Why: by the net in a 0.5 m/s current the
goal can lie a few metres behind, where every 10-decision manoeuvre is carried past it; the
policy, or the stall controller, then flew on and away and timed out. 10 decisions gained nothing
(one goal fewer over the two hardest cells), 15 gained 3 and 10 goals there on two mission sets
(``docs/notes/sessions.md``). The cost: the manoeuvres' points are laid out once per process
(``cage_sim.goal_search.GoalSearch``, 5.7 MB, built by ``prepare`` or at the first search), so a
search tests only the points near the goal and measures each shared way to it once: 0.45 ms p50,
2.0 ms p99 in the decision loop (session 43's, testing every point: 2.7 and 7.3 ms), and through
``policy_node`` at 100 Hz with a search at every decision the p99 is 3.8-4.3 ms (6.9-8.4 ms before;
``benchmarks/bench_latency.py --goal-bearing 180``). ``goal_search`` off (a node parameter) skips it.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from .controller import ArcController, DistinctPoints, Policy, act_rows, nearest_distance
from .goal_search import GoalSearch
from .perception import Perception
from .vehicle import VehicleParams, decision_step

CHUNK = 8   # continuations rolled out at once (the straight one first): most checks stop in the first chunk
TURN_LEVELS = (-1.0, -0.5, 0.5, 1.0)   # the turns a continuation holds (after the straight one)


@dataclass(frozen=True)
class Manoeuvre:
    """A continuation the shield checked: hold ``turn`` for ``hold`` more decisions, then ``then``
    (straight, or in an S-turn another turn)."""

    turn: float
    hold: int
    then: float = 0.0

    def next_action(self) -> float:
        return self.turn if self.hold > 0 else self.then

    def action_at(self, k: int) -> float:
        """The action ``k`` decisions into the continuation."""
        return self.turn if k < self.hold else self.then


@dataclass
class Commitment:
    """One vehicle's memory between the shield's decisions: the manoeuvre that made the last
    override safe (None: the last action was not an override). Why: a shield that picks, each
    decision afresh, the safe action nearest the policy's can swing from a hard left to a hard right
    and back while the policy keeps asking for the same unsafe turn, and fly straight on between them
    into the net (seen in the sea matrix: +0.6, -0.6, +1.0, -1.0 on four decisions toward a wall 5 m
    ahead). Flying on with the manoeuvre that proved the last override safe keeps the vehicle on an
    escape it knows. Only overrides are carried on: carrying the manoeuvre behind every safe policy
    action too (a hard turn where the nearest safe action was a gentle one) cost goals at 0.5 m/s
    (995 -> 989 of 1000, more timeouts) for fewer collisions elsewhere."""

    plan: Manoeuvre | None = None

    def reset(self) -> None:
        self.plan = None


@dataclass
class SafetyShield:
    policy: Policy
    fallback: ArcController = field(default_factory=ArcController)
    horizon: int = 5                 # decisions checked in still water: the first one plus horizon-1 of continuation
    drift_horizon: float = 10.0      # extra decisions per m/s of drift (a 0.5 m/s current: 5 more)
    horizon_max: int = 10
    min_clearance: float = 1.0       # m from every sonar return along the whole manoeuvre
    n_actions: int = 21              # alternative first actions tried when the policy's is unsafe
    open_water: bool = True          # with no return in reach, fly the classical controller's action
    approach: bool = True            # a policy action that circles the goal: the controller's approach instead
    recover: bool = True             # a policy that makes no progress (``StallWatch``): the controller flies
    keep_manoeuvre: bool = True      # right after an override: its manoeuvre's next action first (``Commitment``)
    s_turns: bool = True             # boxed in for held turns: try two-phase continuations (S-turns) too
    sure_approach: bool = True       # the goal in the controller's reach: its manoeuvre through the goal flies
    sure_within: float = 16.0        # m: the goal is looked for nearer than this (10 decisions + 0.5 m/s drift)
    goal_search: bool = True         # no controller manoeuvre through the goal: search longer ones (``through_goal``)
    goal_horizon: int = 15           # decisions such a manoeuvre may take (first action + continuation)
    decisions: int = 0
    interventions: int = 0
    approaches: int = 0              # decisions the orbit guard, sure approach or goal search took (in interventions too)
    recoveries: int = 0              # decisions flown by the controller for a stalled policy (likewise)
    handovers: int = 0               # open water: decisions the controller's action replaced the policy's (likewise)

    def __post_init__(self) -> None:
        if not (1 <= self.horizon <= self.horizon_max) or self.drift_horizon < 0:
            raise ValueError(f"shield horizon: need 1 <= horizon ({self.horizon}) <= horizon_max "
                             f"({self.horizon_max}) and drift_horizon >= 0 ({self.drift_horizon})")
        if self.goal_horizon < 2:
            raise ValueError(f"shield goal_horizon: need >= 2 decisions, got {self.goal_horizon!r}")
        if not self.sure_within > 0:
            raise ValueError(f"shield sure_within: must be > 0 m, got {self.sure_within!r}")
        self._alternatives = np.linspace(-1.0, 1.0, self.n_actions)
        self._conts: dict[tuple[int, bool], np.ndarray] = {}
        self._distinct: dict[int, tuple[np.ndarray, DistinctPoints]] = {}   # id of a continuation set -> its table
        self._tables: dict[tuple[int, bool], GoalSearch] = {}

    def horizon_for(self, drift: np.ndarray | None) -> int:
        """Decisions to check given the drift: a current pushes the vehicle on while it turns away
        (a half turn takes 9 s: 4.5 m at 0.5 m/s), so a state that looks safe for 5 decisions can
        already be one no manoeuvre escapes; the look-ahead grows with the drift to cover the escape."""
        return int(min(self.horizon_max, self.horizon + math.ceil(self.drift_horizon * drift_speed(drift) - 1e-9)))

    def _manoeuvres(self, horizon: int, s_turns: bool = False) -> list[Manoeuvre]:
        """The continuations of ``horizon - 1`` decisions, in ``_continuations``' order."""
        n = horizon - 1
        ms = [self.tail(i, horizon) for i in range(1 + len(TURN_LEVELS) * n)]
        return ms + list(s_turn_manoeuvres(n)) if s_turns else ms

    def _continuations(self, horizon: int, s_turns: bool = False) -> np.ndarray:
        """[C, P, 2] body-frame continuations of ``horizon - 1`` decisions from the origin: straight,
        or a turn of -1, -0.5, 0.5 or 1 held for k decisions and then straight (cached per horizon).
        ``s_turns``: those, then two-phase ones (``s_turn_manoeuvres``), in that order."""
        key = (horizon, s_turns)
        if key not in self._conts:
            n = horizon - 1
            conts = [self._points(m.action_at, n) for m in self._manoeuvres(horizon, s_turns)]
            self._conts[key] = np.array(conts).reshape(len(conts), 2 * n, 2)
        return self._conts[key]

    def _points(self, action_at, n: int) -> np.ndarray:
        """Mid and end points of ``n`` decisions flown from the origin with action_at(h)."""
        return manoeuvre_points(action_at, n, self.fallback.vehicle)

    def safe(self, firsts: np.ndarray, returns: np.ndarray, relative: np.ndarray | None = None,
             goal: np.ndarray | None = None, drift: np.ndarray | None = None,
             horizon: int | None = None) -> np.ndarray:
        """For each first action: does some continuation keep min_clearance from all returns?"""
        look = self._look(returns, relative, goal, drift, horizon)
        return np.array([self._margin(float(a), look, self.min_clearance) >= self.min_clearance for a in firsts])

    def margins(self, firsts: np.ndarray, returns: np.ndarray, relative: np.ndarray | None = None,
                goal: np.ndarray | None = None, drift: np.ndarray | None = None,
                horizon: int | None = None) -> np.ndarray:
        """For each first action, the clearance its best manoeuvre keeps: min over the points flown
        of the distance to the returns, max over the continuations (m; inf with no return).

        ``relative``: (K, 2) drift of the vehicle relative to each return (``Perception.relative``),
        m/s in the body frame; None = still water and static returns. ``goal`` (body frame, the
        mission's final waypoint) with ``drift``: nothing after passing through the goal is checked,
        since the mission ends there (a goal 2.5 m from the net is reachable head-on). ``horizon``:
        decisions checked (default ``horizon_for(drift)``)."""
        return self.horizon_margins(firsts, returns, relative, goal, drift, horizon)[:, -1]

    def horizon_margins(self, firsts: np.ndarray, returns: np.ndarray, relative: np.ndarray | None = None,
                        goal: np.ndarray | None = None, drift: np.ndarray | None = None,
                        horizon: int | None = None, s_turns: bool = False, cap: float | None = None) -> np.ndarray:
        """(F, h): ``margins`` of each first action for every look-ahead 1..h, from one rollout.
        Why one is enough: the continuations of a shorter look-ahead are those of the longer one
        cut short (hold b for j decisions, then straight, for min(j, k-1) of k-1 decisions).

        ``cap``: each margin exact where it is below ``cap``, some value >= ``cap`` (inf) elsewhere.
        Why: the boxed-in choice (``check``) asks of a margin only whether it reaches
        ``min_clearance``, and compares margins that all lie below it; measured exactly, every
        point of every continuation (165 with the S-turns) against every return (200 with a known
        map) made one decision take 31-150 ms (session 45). Capped, each distinct point is measured
        only against the returns near its block (``DistinctPoints``), with the same values below
        the cap, so the same choice (``tests/sim/test_exact_fast_paths.py``)."""
        look = self._look(returns, relative, goal, drift, horizon, s_turns)
        near = None if cap is None else (self._distinct_conts(look[0], look[2]), cap)
        return np.array([self._profile(float(a), look, near) for a in firsts],
                        dtype=np.float64).reshape(len(firsts), -1)

    def _distinct_conts(self, conts: np.ndarray, t_cont: np.ndarray) -> DistinctPoints:
        """The distinct (point, time) pairs of ``conts``, a set ``_continuations`` made (and keeps),
        flown at ``t_cont``: one table per set, kept beside it."""
        key = id(conts)
        if key not in self._distinct or self._distinct[key][0] is not conts:
            self._distinct[key] = (conts, DistinctPoints.of(conts, t_cont))
        return self._distinct[key][1]

    def first_safe(self, candidates, returns: np.ndarray, relative: np.ndarray | None = None,
                   goal: np.ndarray | None = None, drift: np.ndarray | None = None,
                   horizon: int | None = None) -> float | None:
        """The first of ``candidates`` (in order) that ``safe`` accepts, or None: stops at it."""
        found = self._first_safe_at(candidates, self._look(returns, relative, goal, drift, horizon))
        return None if found is None else found[0]

    def _first_safe_at(self, candidates, look: tuple) -> tuple[float, int] | None:
        """(the first safe candidate, the continuation that makes it safe: ``_margin_at``) or None."""
        for a in candidates:
            m, idx = self._margin_at(float(a), look, self.min_clearance)
            if m >= self.min_clearance:
                return float(a), idx
        return None

    def tail(self, index: int, horizon: int) -> "Manoeuvre | None":
        """The rest of continuation ``index`` (of ``horizon``, with the S-turns after the others)
        after the decision it follows has been flown: what the vehicle can fly next and still keep
        the margin it was checked for."""
        if index < 0:
            return None
        if index == 0:
            return Manoeuvre(0.0, 0)
        n = horizon - 1
        if index > len(TURN_LEVELS) * n:
            return s_turn_manoeuvres(n)[index - 1 - len(TURN_LEVELS) * n]
        return Manoeuvre(TURN_LEVELS[(index - 1) // n], (index - 1) % n + 1)

    def _look(self, returns, relative, goal, drift, horizon, s_turns: bool = False) -> tuple:
        """What every first action's check shares: continuations, their times, the returns' motion."""
        h = self.horizon_for(drift) if horizon is None else int(horizon)
        return (self._continuations(h, s_turns), *self._motion(returns, relative, goal, drift, h))

    def _motion(self, returns, relative, goal, drift, h: int) -> tuple:
        """``_look`` without the continuations (the goal search has its own table): the times of the
        first decision's points and of the continuation's, the returns, their relative motion, the
        goal, the drift."""
        period = self.fallback.vehicle.decision_period
        t_cont = period + np.tile([0.5, 1.0], h - 1) * period + np.repeat(np.arange(h - 1), 2) * period
        returns = np.asarray(returns, dtype=np.float64).reshape(-1, 2)
        rel = np.zeros_like(returns) if relative is None else np.asarray(relative, dtype=np.float64).reshape(-1, 2)
        dr = np.zeros(2) if drift is None else np.asarray(drift, dtype=np.float64)
        return np.array([0.5, 1.0]) * period, t_cont, returns, rel, goal, dr

    def _first(self, a: float, look: tuple) -> tuple[float, bool, tuple[float, float, float]]:
        """The first decision flown with action ``a``: (its clearance, whether it passes through
        the goal (then nothing after it counts), its end pose)."""
        _, t_first, _, returns, rel, goal, dr = look
        x1, y1, yaw1 = decision_step(0.0, 0.0, 0.0, a, self.fallback.vehicle)
        first0 = np.array([(0.5 * x1, 0.5 * y1), (x1, y1)])                          # chord points
        d_first = nearest_distance(first0, t_first, rel, returns)   # [2]
        if goal is not None:
            hit = np.linalg.norm(first0 + t_first[:, None] * dr - goal, axis=1) < self.fallback.goal_pass
            if hit.any():
                return float(d_first[: int(np.argmax(hit)) + 1].min()), True, (x1, y1, yaw1)
        return float(d_first.min()), False, (x1, y1, yaw1)

    def _along(self, conts: np.ndarray, end: tuple[float, float, float], look: tuple,
               near: tuple[DistinctPoints, float] | None = None) -> np.ndarray:
        """[C, P] clearance at each point of the continuations ``conts`` flown from ``end`` (inf
        after one passes through the goal). ``near``: (``conts``' distinct pairs, cap): exact
        below the cap only (``horizon_margins``)."""
        _, _, t_cont, returns, rel, goal, dr = look
        x1, y1, yaw1 = end
        c, s = math.cos(yaw1), math.sin(yaw1)
        cont0 = conts @ np.array([[c, s], [-s, c]]) + (x1, y1)                          # [C, P, 2]
        if near is None:
            d = nearest_distance(cont0, t_cont[None, :], rel, returns)
        else:
            table, cap = near
            d = table.nearest_below(cont0.reshape(-1, 2)[table.index], rel, returns, cap)[table.inverse]
            d = d.reshape(cont0.shape[:2])
        if goal is not None:
            hit = np.cumsum(np.linalg.norm(cont0 + t_cont[None, :, None] * dr - goal, axis=-1)
                            < self.fallback.goal_pass, axis=1)
            d = np.where(np.concatenate([np.zeros_like(hit[:, :1]), hit[:, :-1]], axis=1) > 0, np.inf, d)
        return d

    def _margin(self, a: float, look: tuple, floor: float = -math.inf) -> float:
        """``margins`` for one first action, exact with no ``floor``. With one, it stops early and
        only tells which side of ``floor`` the margin lies: below it after the first decision (the
        continuations are not rolled out), at or above it at the first continuation that clears it."""
        return self._margin_at(a, look, floor)[0]

    def _margin_at(self, a: float, look: tuple, floor: float = -math.inf, capped: bool = True) -> tuple[float, int]:
        """(``_margin``, index of the continuation that keeps it: the first that clears ``floor``,
        else the best; -1 when none is flown: the first decision passes through the goal or already
        falls below ``floor``). With a ``floor`` the margin is exact where it clears it; below it,
        it only says so (``_first_clearing``; ``capped=False``: every chunk measured exactly in
        turn, the plain loop the tests hold it to)."""
        conts = look[0]
        m, through, end = self._first(a, look)
        if through or m < floor:
            return m, -1
        best, idx = -math.inf, -1
        for lo in range(0, len(conts), CHUNK):    # stop at the first continuation that clears ``floor``
            if capped and lo == CHUNK and floor > -math.inf:
                return self._first_clearing(m, end, look, floor)
            d = self._along(conts[lo:lo + CHUNK], end, look).min(axis=1, initial=np.inf)
            j = int(np.argmax(d)) if len(d) else 0
            if len(d) and float(d[j]) > best:
                best, idx = float(d[j]), lo + j
            if best >= floor > -math.inf:
                break
        return min(m, best), idx

    def _first_clearing(self, m: float, end: tuple[float, float, float], look: tuple, floor: float
                        ) -> tuple[float, int]:
        """``_margin_at`` past its first chunk of continuations, which did not clear ``floor``: the
        chunk the loop would stop at is found with every continuation's clearance capped at
        ``floor`` (``horizon_margins``), and only that chunk is measured exactly, so the index (the
        best of that chunk) is the loop's. Why: when no action is safe (boxed in), the loop
        measured all 165 continuations of all 21 actions against every return: 40-70 ms of a
        decision (session 46's trace of sea cell 23). None clears: (the best capped margin, below
        ``floor``, -1)."""
        conts = look[0]
        table = self._distinct_conts(conts, look[2])
        d = self._along(conts, end, look, (table, floor))[CHUNK:].min(axis=1, initial=np.inf)
        clear = np.flatnonzero(d >= floor)
        if len(clear) == 0:
            return min(m, float(d.max(initial=-math.inf))), -1
        lo = CHUNK + (int(clear[0]) // CHUNK) * CHUNK
        exact = self._along(conts[lo:lo + CHUNK], end, look).min(axis=1, initial=np.inf)
        j = int(np.argmax(exact))
        return min(m, float(exact[j])), lo + j

    def _profile(self, a: float, look: tuple, near: tuple[DistinctPoints, float] | None = None) -> np.ndarray:
        """[h] the margin of ``a`` for look-aheads 1..h: the running minimum along each continuation,
        read at the end of each of its decisions, best continuation (``near``: capped, ``_along``).
        Capped is exact below the cap: a running minimum or a best below it is made of values
        below it, and one at or above it stays there."""
        conts = look[0]
        m, through, end = self._first(a, look)
        n = conts.shape[1] // 2
        if through or n == 0:
            return np.full(n + 1, m)
        run = np.minimum.accumulate(self._along(conts, end, look, near), axis=1)[:, 1::2].max(axis=0)   # [n]
        return np.minimum(m, np.concatenate([[m], run]))

    def act_one(self, obs: np.ndarray) -> float:
        dist, err = self.fallback.layout.waypoint_from(obs)
        return self.decide(obs, float(dist), float(err), self.fallback.perceive(obs))

    def decide(self, obs: np.ndarray, dist: float, err: float, p: Perception) -> float:
        """The policy's action for ``obs``, or the nearest safe one given what is perceived."""
        return self.check(float(np.asarray(self.policy.act(obs), dtype=np.float64).reshape(-1)[0]), dist, err, p)

    def check(self, action: float, dist: float, err: float, p: Perception, stalled: bool = False,
              commit: Commitment | None = None, controller_choice: tuple[float, bool] | None = None) -> float:
        """``action`` (the policy's, already computed) if it is safe, else the nearest safe one.
        ``controller_choice``: ``fallback.choose(dist, err, p)`` when the caller has it already (a
        residual policy's base action is that very action), so it is not computed twice.
        ``stalled`` (the vehicle's ``StallWatch`` says so): the controller's action instead, checked
        like the policy's. ``commit`` (the vehicle's ``Commitment``): an unsafe action right after an
        override is replaced first by the next action of the manoeuvre that made that override safe,
        if it is still safe, and only then by the nearest safe one; every override leaves its
        manoeuvre there, every other action clears it.

        Open water (no return within the classical controller's reach, ~12 m): the controller's
        action, i.e. fly at the waypoint (crabbing against the drift) or through the goal. Nothing
        there gives a reason to turn away, and a policy that rarely saw an empty scan in training may
        (the shipped study policy turned hard left with the waypoint dead ahead), or may circle a goal."""
        a = float(np.clip(action, -1.0, 1.0))
        self.decisions += 1
        def choice() -> tuple[float, bool]:
            b, through = self.fallback.choose(dist, err, p) if controller_choice is None else controller_choice
            return float(b), bool(through)

        if self.open_water and len(p.returns) == 0:
            b = choice()[0]
            self.interventions += int(abs(b - a) > 0.05)
            self.handovers += int(abs(b - a) > 0.05)
            self._remember(commit, -1, 0)
            return b
        handed = stalled or (self.approach and p.final and orbits_goal(a, dist, err, self.fallback.vehicle,
                                                                       self.fallback.goal_pass, p.drift))
        sure = self.sure_approach and p.final and dist < self.sure_within
        through, guarded = False, handed                    # through: a controller manoeuvre through the goal
        if handed:
            a, through = choice()                           # checked below like any other action
            self.recoveries += int(stalled)
            self.approaches += int(not stalled)
            self.interventions += 1
        elif sure:
            b, through = choice()
            if through and abs(b - a) > 1e-9:               # the controller's manoeuvre ends the mission
                a, guarded = b, True
                self.approaches += 1
                self.interventions += 1
        h = self.horizon_for(p.drift)
        v = self.fallback.vehicle
        drift_reach = float(np.abs(p.relative()).max(initial=0.0)) * h * v.decision_period \
            if len(p.returns) else 0.0
        reach = v.step_length * h + self.min_clearance + 0.5 + drift_reach
        near = np.linalg.norm(p.returns, axis=1) < reach if len(p.returns) else np.zeros(0, dtype=bool)
        returns, rel = p.returns[near], p.relative()[near]
        goal = np.array([dist * math.cos(err), dist * math.sin(err)]) if p.final else None
        if len(returns) == 0:
            self._remember(commit, -1, h)
            return a
        if sure and self.goal_search and not through:
            found = self.through_goal(a, p, goal, h, reach)
            if found is not None:                           # a clear way through the goal: it ends the mission
                if not handed and abs(found - a) > 1e-9:    # (a handed decision is counted already)
                    self.approaches += 1
                    self.interventions += 1
                self._remember(commit, -1, h)
                return found
        look = self._look(returns, rel, goal, p.drift, h)
        if self._margin(a, look, self.min_clearance) >= self.min_clearance:
            self._remember(commit, -1, h)     # the policy's own action: no override to carry on
            return a
        self.interventions += int(not guarded)          # one override per decision, however many steps
        nearest_first = self._alternatives[np.argsort(np.abs(self._alternatives - a), kind="stable")]
        plan = commit.plan if commit is not None and self.keep_manoeuvre else None
        candidates = nearest_first if plan is None else np.concatenate([[plan.next_action()], nearest_first])
        found = self._first_safe_at(candidates, look)
        if found is None and self.s_turns:     # boxed in for held turns: an S-turn may still keep clear
            found = self._first_safe_at(nearest_first, self._look(returns, rel, goal, p.drift, h, s_turns=True))
        if found is not None:
            self._remember(commit, found[1], h)
            return found[0]
        self._remember(commit, -1, h)
        # No action is safe over the whole look-ahead. The longest look-ahead some action survives,
        # down to the still-water horizon; among the actions that survive it, the one whose best
        # manoeuvre keeps farthest from the returns over the whole look-ahead (ties: the nearest the
        # policy's): the nearest barely-safe action tends to box the vehicle in a decision later.
        margin = self.horizon_margins(nearest_first, returns, rel, goal, p.drift, h, self.s_turns,
                                      cap=self.min_clearance)     # [F, h], exact below min_clearance
        for k in range(h - 1, self.horizon - 1, -1):
            ok = margin[:, k - 1] >= self.min_clearance
            if ok.any():
                return float(nearest_first[ok][int(np.argmax(margin[ok, -1]))])
        return float(nearest_first[int(np.argmax(margin[:, -1]))])

    def through_goal(self, action: float, p: Perception, goal: np.ndarray, h: int, reach: float) -> float | None:
        """The first action of the manoeuvre that passes through ``goal`` (body frame) soonest and
        keeps ``min_clearance`` from the returns up to it, among every alternative first action
        followed by every continuation of ``goal_horizon`` decisions (held turns and S-turns), or
        None; ties: the action nearest ``action``. ``h``, ``reach``: the look-ahead and the reach of
        the returns of the check it stands in for (the returns are taken as far out as the longer
        manoeuvres fly).

        Why: in a strong drift by the net no 10-decision manoeuvre of the controller's may reach a
        goal a few metres off (it lies behind, and the current carries every turn past it), so the
        policy or the stall controller flew on and away (cell 23 mission 15 of the sea matrix: the
        goal 5.6 m off for 10 decisions, then a timeout); a 15-decision one, a turn and then another,
        does. Measured in ``docs/notes/sessions.md`` (session 43)."""
        gh = max(h, self.goal_horizon)
        near = np.linalg.norm(p.returns, axis=1) < reach + self.fallback.vehicle.step_length * (gh - h)
        motion = self._motion(p.returns[near], p.relative()[near], goal, p.drift, gh)
        return self._through_goal(action, motion, self._goal_table(gh))

    def _through_goal(self, action: float, motion: tuple, table: GoalSearch) -> float | None:
        """``through_goal`` over the manoeuvres of ``table`` (every alternative first action followed
        by every continuation), ``motion`` as ``_motion`` gives it: ``GoalSearch.find``, the policy's
        nearest first action first."""
        t_first, t_cont, returns, rel, goal, dr = motion
        rank = np.argsort(np.argsort(np.abs(self._alternatives - action), kind="stable"))
        found = table.find(rank, goal, dr, t_first, t_cont, returns, rel, self.fallback.goal_pass,
                           self.min_clearance)
        return None if found is None else float(self._alternatives[found])

    def _goal_table(self, horizon: int) -> GoalSearch:
        """The goal search's table for manoeuvres of ``horizon`` decisions (``goal_table``)."""
        key = (horizon, self.s_turns)
        if key not in self._tables:
            self._tables[key] = goal_table(self.fallback.vehicle, tuple(self._alternatives.tolist()),
                                           tuple(self._manoeuvres(horizon, self.s_turns)), horizon - 1)
        return self._tables[key]

    def prepare(self) -> "SafetyShield":
        """Build the goal search's tables now rather than at the first search (about 50 ms each,
        shared by every shield of the process): a node's first search is then as fast as the rest."""
        if self.goal_search:
            for h in range(self.horizon, self.horizon_max + 1):
                self._goal_table(max(h, self.goal_horizon))
        return self

    def _remember(self, commit: Commitment | None, index: int, horizon: int) -> None:
        """Leave in ``commit`` the manoeuvre (continuation ``index`` of ``horizon``) that made the
        action flown safe, or nothing when none is known."""
        if commit is not None:
            commit.plan = self.tail(index, horizon)

    def act(self, obs: np.ndarray) -> np.ndarray:
        return act_rows(self.act_one, obs)


def manoeuvre_points(action_at, n: int, vehicle: VehicleParams) -> np.ndarray:
    """[2n, 2] mid and end points of ``n`` decisions flown from the origin with ``action_at(h)``."""
    x = y = yaw = 0.0
    pts = []
    for h in range(n):
        x0, y0 = x, y
        x, y, yaw = decision_step(x, y, yaw, action_at(h), vehicle)
        pts += [(0.5 * (x0 + x), 0.5 * (y0 + y)), (x, y)]
    return np.array(pts).reshape(-1, 2)


@functools.lru_cache(maxsize=16)
def goal_table(vehicle: VehicleParams, firsts: tuple[float, ...], manoeuvres: tuple[Manoeuvre, ...],
               n: int) -> GoalSearch:
    """The goal search's table (``GoalSearch``): each first action of ``firsts`` followed by each
    of the ``manoeuvres`` of ``n`` decisions. Cached per process: it depends on none of the scan."""
    ends = np.array([decision_step(0.0, 0.0, 0.0, float(b), vehicle) for b in firsts])
    conts = np.array([manoeuvre_points(m.action_at, n, vehicle) for m in manoeuvres]).reshape(len(manoeuvres), 2 * n, 2)
    actions = np.array([[m.action_at(j) for j in range(n)] for m in manoeuvres]).reshape(len(manoeuvres), n)
    return GoalSearch.build(ends, conts, actions)


@functools.lru_cache(maxsize=None)
def s_turn_manoeuvres(n: int) -> tuple[Manoeuvre, ...]:
    """Two-phase continuations of ``n`` decisions: hold ``b1`` (straight or a turn level) for k
    decisions (1 <= k < n), then another turn level ``b2`` to the end. Why: in a current onto an
    obstacle the only way out can be a gentle turn one way, then a full turn the other (cell 19
    mission 911 of the sea matrix: -0.5 for 3 decisions, then +1), which no held turn flies."""
    return tuple(Manoeuvre(b1, k, b2) for b1 in (0.0, *TURN_LEVELS) for k in range(1, n)
                 for b2 in TURN_LEVELS if b2 != b1)


def drift_speed(drift: np.ndarray | None) -> float:
    """m/s of a body-frame drift (None: still water)."""
    return 0.0 if drift is None else float(np.hypot(*np.asarray(drift, dtype=np.float64)[:2]))


def orbits_goal(action: float, dist: float, err: float, vehicle: VehicleParams, reach: float,
                drift: np.ndarray | None = None) -> bool:
    """Whether ``action`` turns toward a goal that no held turn that way can reach: the goal
    (body frame: ``dist`` m at bearing ``err``, left positive) lies more than ``reach`` inside the
    full-turn circle on the side ``action`` turns to.

    Why: the learned policies turn hard at a goal that lies beside them, and a goal inside the
    tightest circle is never reached (the policies orbited it until timeout). Holding ``a`` flies a
    circle of radius ``step_length / (|a| max_turn)`` tangent to the heading; on one side these
    circles are nested, the full turn's (2.9 m) innermost, so a goal inside it is inside them all.
    A goal inside a gentle turn's circle but outside the full turn's is left to the policy: turning
    harder still reaches it. (The first version tested the policy's own circle: the same outcomes
    on the still-water cells, but it took over five times as many decisions.)
    Only a closed circle orbits: with a ``drift`` that carries it ``reach`` or more per turn
    (0.05 m/s) the track is a trochoid that sweeps on, so this says False (taking over there cost
    goal rate at 0.5 m/s: 99.2 -> 98.5 % in an fls cell, more timeouts)."""
    if abs(action) < 0.05:
        return False
    r = vehicle.step_length / vehicle.max_turn
    if drift_speed(drift) * 2 * math.pi * r / vehicle.speed >= reach:
        return False
    gx, gy = dist * math.cos(err), dist * math.sin(err)
    return math.hypot(gx, gy - math.copysign(r, action)) < r - reach
