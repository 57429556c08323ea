"""From what a vehicle has at a decision to an action: the one code path of the evaluator and policy_node.

Why one module: a policy must behave the same in the node graph as in offline evaluation. The
observation (layout, memory across scans, velocity over ground), the perception the shield and the
baseline get (drift from the DVL, the motion of returns across scans, "the waypoint is the goal")
and the choice between the policy's action and the shield's are all made here, so the evaluator
(batched over many missions) and the node (one vehicle) cannot drift apart. Pure: no ROS import.

  driver = Driver(policy, layout, vehicle)            # one per vehicle; driver.reset() per mission
  action, shielded = driver.decide(scan, pose, t, v_ground_body, tracker)
  actions, shielded = decide_batch(drivers, obs, moments)   # the evaluator: one batched forward
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .controller import ArcController, Policy
from .map_points import MapPoints
from .observation import ObservationBuilder
from .perception import Perception, ReturnMotion, body_drift, perceive
from .route import RouteTracker, StallWatch
from .shield import Commitment, SafetyShield
from .sonar import Scan, SonarModel, make_sonar
from .vehicle import VehicleParams


#: The remembered returns the flown drivers' shield and the classical baseline count (``evaluate
#: --remembered``, policy_node's ``remembered_returns``; ``ArcController.remembered``): since session
#: 53 "cleared". ``ArcController``'s own default stays "all": what the residual policies' base
#: controllers were trained with, and what their raw flights keep.
DEFAULT_REMEMBERED = "cleared"


@dataclass(frozen=True)
class Moment:
    """What a vehicle knows at a decision besides its observation."""

    pose: tuple[float, float, float]   # x, y, yaw (map frame)
    t: float                           # sim time, s
    v_ground: tuple[float, float] | None   # DVL: body-frame velocity over ground (None: unknown -> no drift)
    final: bool                        # the waypoint is the mission's goal
    remaining: float | None = None     # m of route left (the stall watch); None: unknown


def mission_moment(m) -> Moment:
    """A simulated ``cage_sim.mission.Mission``'s moment: pose, time, the DVL's body-frame velocity
    over ground (as vehicle_node publishes it), whether the waypoint is the goal, the route left."""
    return Moment(m.pose, m.t, m.velocity_over_ground(), m.tracker.at_last, m.tracker.remaining(m.x, m.y))


class Driver:
    """One vehicle's decision maker: the policy (raw, behind the shield, or the classical baseline),
    an ``ObservationBuilder`` for the policy's layout and a ``ReturnMotion`` (state across scans).

    ``perception=False``: the shield and the baseline read the observation alone (static returns,
    drift only from a v2 velocity), the drift-free reference of the evaluator. Behind a shield whose
    ``recover`` is on, a ``StallWatch`` hands a policy that makes no progress to the controller.
    ``known``: the known map (``MapPoints``) the shield keeps clear of beside the returns (None: the
    returns alone); the policy, a residual policy's base and the baseline never see it.
    ``sonar``: the sonar the scans come from (None: the layout's profile as defined); its beams'
    width says what a beam has seen past when the controller that perceives (the shield's or the
    baseline's, else a raw residual policy's base) reads the memory ``remembered="cleared"``
    (beside a 360 deg scan it reads none: nothing is cleared, nothing paid)."""

    def __init__(self, policy: Policy, layout, vehicle: VehicleParams | None = None,
                 builder: ObservationBuilder | None = None, perception: bool = True,
                 known: MapPoints | None = None, sonar: SonarModel | None = None):
        self.policy = policy
        self.known = known
        self.layout = layout
        self.vehicle = vehicle or VehicleParams()
        ctrl = perceiver(policy)
        self._cone = 0.5 * (sonar or make_sonar(layout.profile)).beam_width \
            if perception and ctrl is not None and ctrl.remembered == "cleared" and ctrl.reads_memory else None
        self.use_builder(builder or ObservationBuilder(layout))
        self.motion = ReturnMotion() if perception else None
        self.stall = StallWatch() if perception else None     # used behind a shield with ``recover`` on
        self.commit = Commitment() if perception else None    # the shield's manoeuvre in hand (shield.py)

    def use_builder(self, builder: ObservationBuilder) -> None:
        """Read the memory of ``builder``, the one that builds this vehicle's observations (a
        mission's, offline): with ``remembered="cleared"`` the controller reads what it cleared."""
        self.builder = builder
        if self._cone is not None and builder.memory is not None:
            builder.clear_with(self._cone)

    def remembered_now(self, mo: "Moment") -> np.ndarray | None:
        """The memory histogram without its cleared returns at this decision, for a controller that
        reads it (``remembered="cleared"``), else None (the observation's memory is read)."""
        b = self.builder
        if self._cone is None or b.memory is None:
            return None
        if b.last_t != mo.t:
            raise RuntimeError("remembered 'cleared': this observation was not built by the driver's builder "
                               "(Driver.use_builder with the builder that builds it)")
        return b.memory.histogram(*mo.pose, include_cleared=False)

    def reset(self) -> None:
        """A new mission: forget the memory, the previous scan's returns and the route's progress."""
        self.builder.reset()
        if self.motion is not None:
            self.motion.reset()
        if self.stall is not None:
            self.stall.reset()
        if self.commit is not None:
            self.commit.reset()

    def observe(self, scan: "Scan | np.ndarray", pose, t: float, v_ground, dist: float, err: float) -> np.ndarray:
        """The policy's observation from a scan (a ``Scan`` with beam stamps, or plain ranges of now)."""
        v = None
        if getattr(self.layout, "velocity", False):   # unknown: the commanded through-water velocity (no drift)
            v = v_ground if v_ground is not None else (self.vehicle.speed, 0.0)
        x, y, yaw = pose
        if isinstance(scan, Scan):
            return self.builder.build_scan(scan, x, y, yaw, t, dist, err, v)
        return self.builder.build(scan, x, y, yaw, t, dist, err, v)

    def decide(self, scan: "Scan | np.ndarray", pose, t: float, v_ground, tracker: RouteTracker) -> tuple[float, bool]:
        """(action in [-1, 1], whether the shield replaced the policy's action) for one decision;
        ``tracker`` already advanced to ``pose``."""
        dist, err = tracker.waypoint(*pose)
        obs = self.observe(scan, pose, t, v_ground, dist, err)
        acts, shielded = decide_batch([self], obs[None], [Moment(tuple(pose), t, v_ground, tracker.at_last,
                                                                 tracker.remaining(*pose[:2]))])
        return float(acts[0]), bool(shielded[0])


def controller_of(policy: Policy) -> ArcController | None:
    """The classical controller that perceives for ``policy`` (the shield's fallback, or the baseline)."""
    if isinstance(policy, SafetyShield):
        return policy.fallback
    return policy if isinstance(policy, ArcController) else None


def residual_base(policy) -> ArcController | None:
    """The controller whose action a residual policy moves (``residual_base`` attribute), else None."""
    return getattr(policy, "residual_base", None)


def perceiver(policy: Policy) -> ArcController | None:
    """The controller whose perception a driver flies: the shield's fallback or the baseline, else a
    raw residual policy's base (None: a plain raw policy, which reads its observation alone). One
    answer for ``Driver`` (whether to clear the memory) and ``decide_batch`` (whose returns)."""
    return controller_of(policy) or residual_base(policy)


def fallback_for(policy, layout, vehicle: VehicleParams | None = None, remembered: str = "all") -> ArcController:
    """The shield's fallback controller for ``policy``: a residual policy's base's parameters (the
    controller it learnt to correct; ``decide_batch`` then decides once for both), else the default.
    ``remembered``: which remembered returns the shield's perception counts (``ArcController``)."""
    return fallback_like(residual_base(policy), layout, vehicle, remembered)


def fallback_like(base: ArcController | None, layout, vehicle: VehicleParams | None = None,
                  remembered: str = "all") -> ArcController:
    """A new controller with ``base``'s parameters (None: the default's): ``fallback_for`` for a
    policy whose base is known before the policy is (the trainer's, ``ShieldFilter``)."""
    tun = {**(base.tunables() if base is not None else {}), "remembered": remembered}
    return ArcController(layout, vehicle, **tun) if vehicle is not None else ArcController(layout, **tun)


def same_decisions(a: ArcController, b: ArcController) -> bool:
    """Whether two controllers decide alike from the same (dist, err, perception): the same
    parameters and vehicle (``decide`` reads nothing else), so one's action stands for the other's."""
    return a is b or (a.tunables() == b.tunables() and a.vehicle == b.vehicle)


def decide_batch(drivers: Sequence[Driver], obs: np.ndarray, moments: Sequence[Moment]) -> tuple[np.ndarray, np.ndarray]:
    """Actions (B,) clipped to [-1, 1] and shielded flags (B,) for drivers sharing one policy: one
    batched forward of the learned policy, then each vehicle's shield or baseline with its own
    ``Perception``. A raw policy (or perception off) reads only its observation; a residual policy
    (``residual_base``) gets its base action from the controller with that perception, made once
    per decision and shared with the shield (``ReturnMotion`` sees every scan once); with a known map
    (``Driver.known``) the shield reads the scan and the map, the base the scan alone, both choices
    made from one clearance of the returns (``ArcController.choose_twice``)."""
    policy = drivers[0].policy
    shield = policy if isinstance(policy, SafetyShield) else None
    learned = shield.policy if shield is not None else policy
    base = residual_base(learned)
    ctrl = perceiver(policy)
    n = len(drivers)
    if ctrl is None or drivers[0].motion is None:
        before = getattr(policy, "interventions", 0)
        acts = np.asarray(policy.act(obs), dtype=np.float64).reshape(n, -1)[:, 0]
        flags = np.full(n, getattr(policy, "interventions", 0) != before and n == 1)
        return np.clip(acts, -1.0, 1.0), flags
    seen = []
    for d, o, mo in zip(drivers, obs, moments):
        dist, err = ctrl.layout.waypoint_from(o)
        drift = body_drift(mo.v_ground, d.vehicle.speed) if mo.v_ground is not None else None
        mem = d.remembered_now(mo)
        seen.append((float(dist), float(err), perceive(ctrl.returns(o, memory=mem), mo.pose, mo.t, drift, mo.final,
                                                       d.motion)))
    if base is None and shield is None:          # the classical baseline
        return np.clip([ctrl.decide(*s) for s in seen], -1.0, 1.0), np.zeros(n, dtype=bool)
    # The known map's points near each vehicle, for the shield (as far out as the returns are kept).
    extras = [d.known.near(mo.pose, ctrl.reach) if shield is not None and d.known is not None else None
              for d, mo in zip(drivers, moments)]
    based = shielded_choice = None
    if base is not None:
        share = shield is not None and same_decisions(base, shield.fallback)
        pairs = [base.choose_twice(*s, x) if share and x is not None and len(x) else (base.choose(*s),) * 2
                 for s, x in zip(seen, extras)]   # (action, through the goal) without and with the map
        based = [b for b, _ in pairs]
        shielded_choice = [c for _, c in pairs] if share else None   # what the shield's fallback chooses
        raw = learned.act_residual(obs, np.array([b for b, _ in based]))
    else:
        raw = learned.act(obs)
    raw = np.asarray(raw, dtype=np.float64).reshape(n, -1)[:, 0]
    if shield is None:
        return np.clip(raw, -1.0, 1.0), np.zeros(n, dtype=bool)
    out, flags = np.empty(n), np.zeros(n, dtype=bool)
    for j, (d, mo, (dist, err, p)) in enumerate(zip(drivers, moments, seen)):
        before = shield.interventions
        stalled = shield.recover and d.stall is not None and mo.remaining is not None \
            and d.stall.update(mo.remaining)
        out[j] = shield.check(raw[j], dist, err, with_map(p, extras[j]), stalled, d.commit,
                              None if shielded_choice is None else shielded_choice[j])
        flags[j] = shield.interventions != before
    return np.clip(out, -1.0, 1.0), flags


def with_map(p: Perception, extra: np.ndarray | None) -> Perception:
    """``p`` with the known map's points ``extra`` (body frame, ``MapPoints.near``) added to its
    returns (static: the map does not move), or ``p`` itself when there are none. The shield's
    perception: a residual policy's base keeps ``p``, what it was trained on."""
    if extra is None or not len(extra):
        return p
    vel = p.velocities if p.velocities is not None else np.zeros_like(p.returns)
    return Perception(np.concatenate([p.returns, extra]), np.concatenate([vel, np.zeros_like(extra)]),
                      p.drift, p.final)


class ObservationLabeller:
    """Expert labels for training (``expert: baseline``): ``policy.act`` on the observation alone."""

    def __init__(self, policy: Policy):
        self.policy = policy

    def __call__(self, obs: np.ndarray, missions: Sequence, finals: Sequence[tuple[int, np.ndarray]] = ()
                 ) -> tuple[np.ndarray, np.ndarray]:
        """(labels of ``obs`` (n, 1), labels of each ended mission's last observation (n, 1), NaN
        where none ended); ``missions`` the env's missions now (unused here)."""
        final = np.full((len(obs), 1), np.nan, dtype=np.float32)
        for i, o in finals:
            final[i] = np.asarray(self.policy.act(o), dtype=np.float32).reshape(-1)[:1]
        return np.asarray(self.policy.act(obs), dtype=np.float32).reshape(len(obs), 1), final


class FlownLabeller(ObservationLabeller):
    """Expert labels for training (``expert: flown``): the classical baseline as the evaluator and
    policy_node fly it, one ``Driver`` per env (drift from the DVL, the returns' motion across
    scans, the final approach when the waypoint is the goal). Why: the observation alone hides
    the last two, and the controller reading only the observation times out near the goal far
    more often (orbits) than the flown baseline; a residual policy's base must be what the graph
    computes. Called on every observation an env returns, in order; a new mission object resets
    its env's driver, which then reads that mission's memory (``Driver.use_builder``: a controller
    with ``remembered="cleared"`` counts what the mission's sonar has not seen past since).
    ``sonar``: the envs' sonar (its beams' width clears the memory; None: the profile's own)."""

    def __init__(self, controller: ArcController, sonar: SonarModel | None = None):
        super().__init__(controller)
        self.sonar = sonar
        self.drivers: list[Driver] = []
        self.missions: list = []

    def __call__(self, obs, missions, finals=()):
        final = np.full((len(obs), 1), np.nan, dtype=np.float32)
        for i, o in finals:        # the ended mission's last decision, with its own driver
            final[i] = decide_batch([self.drivers[i]], o[None], [mission_moment(self.missions[i])])[0][0]
        while len(self.drivers) < len(missions):
            self.drivers.append(Driver(self.policy, self.policy.layout, self.policy.vehicle, sonar=self.sonar))
            self.missions.append(None)
        for i, m in enumerate(missions):
            if self.missions[i] is not m:
                self.drivers[i].reset()
                self.drivers[i].use_builder(m.builder)   # the memory its observations are built with
                self.missions[i] = m
        acts, _ = decide_batch(self.drivers[:len(missions)], obs, [mission_moment(m) for m in missions])
        return acts.astype(np.float32).reshape(-1, 1), final


class Proposals:
    """The actions a trainer's actor proposes this step, as the policy a ``SafetyShield`` checks."""

    def __init__(self) -> None:
        self.actions = np.zeros(0)

    def act(self, obs: np.ndarray) -> np.ndarray:
        return np.asarray(self.actions, dtype=np.float64).reshape(len(obs), 1)


class ShieldFilter:
    """The safety shield between a training actor and its missions (``train`` with ``shield_in_loop``).

    Why: the shipped drivers fly a policy behind the shield, but a policy trained without it never
    meets the states an override leaves it in (one override turns the vehicle 10-20 deg off the line
    the policy was on), and in strong current it can answer with turns no override would have led
    to. Here every proposed action goes through the very shield the evaluator and policy_node fly
    (``decide_batch``: drift from the DVL, the returns' motion across scans, the known map, the
    stall watch and the manoeuvre in hand), one ``Driver`` per env, reset when its mission changes;
    the env flies what the shield lets through. Called once per env step with the observation the
    proposals were made on (each ``ReturnMotion`` sees every scan once).

    The flags it returns mark proposals the shield found unsafe and replaced. The controller's
    handovers (open water, the goal approach, a stalled policy) replace a proposal too, but they say
    nothing about its safety: in open water any exploration noise would count, a third of all
    decisions in training."""

    def __init__(self, fallback: ArcController, known_map: bool = True):
        """``fallback``: the shield's controller, as the evaluator would give the trained policy
        (``fallback_like``: a residual actor's base's parameters, else the default's)."""
        self.proposals = Proposals()
        self.shield = SafetyShield(self.proposals, fallback)
        self.known_map = known_map
        self.drivers: list[Driver] = []
        self.missions: list = []

    def handed(self) -> int:
        """Decisions so far that the controller's action flew by the shield's rules, not for safety."""
        return self.shield.handovers + self.shield.approaches + self.shield.recoveries

    def __call__(self, actions: np.ndarray, obs: np.ndarray, missions: Sequence) -> tuple[np.ndarray, np.ndarray]:
        """(the actions flown (n,), whether the shield replaced each proposal as unsafe (n,))."""
        ctrl = self.shield.fallback
        n = len(missions)
        while len(self.drivers) < n:
            self.drivers.append(Driver(self.shield, ctrl.layout, ctrl.vehicle))
            self.missions.append(None)
        proposed = np.clip(np.asarray(actions, dtype=np.float64).reshape(n), -1.0, 1.0)
        flown, unsafe = np.empty(n), np.zeros(n, dtype=bool)
        for i, (d, o, m) in enumerate(zip(self.drivers, obs, missions)):
            if self.missions[i] is not m:
                d.reset()
                d.known = m.map_points if self.known_map else None
                self.missions[i] = m
            self.proposals.actions = proposed[i:i + 1]
            handed = self.handed()
            a, replaced = decide_batch([d], o[None], [mission_moment(m)])
            flown[i], unsafe[i] = a[0], bool(replaced[0]) and self.handed() == handed
        return flown, unsafe
