"""policy_node: scan + pose + plan -> next waypoint -> heading setpoint, one decision per metre.

Builds the observation with the same layout, route tracker and vehicle facts as the offline env, and
asks the same policy (a file from the ``policy`` parameter, ``baseline`` for the classical controller,
or by default the shipped DDPG weights: the driver of the ``sensor`` profile when one is named,
``policy.DRIVERS``), so a seeded mission ends in the graph as it does offline.
A learned policy runs behind the safety shield (``cage_sim.shield``; parameter ``shield``, default
on), as it does in the evaluator by default.

Safety: weights that do not match this build are refused at start (exit 2, naming the mismatch).
A scan of the wrong size, or with too many invalid (NaN / negative) ranges, gets a failsafe
setpoint (hold station) and a FAILSAFE mission event instead of a decision; scans that stop coming
are reported the same way. With no progress along the route for ``replan_after`` decisions, or
farther than ``replan_offset`` from the route, the node asks the global planner for a new plan from
where the vehicle is (REPLAN_REQUESTED on ``mission_event``; ``cage_sim.route.ReplanWatch``). In
lockstep it holds that decision until the new plan arrives (at most ``replan_wait`` wall seconds,
then it flies on with the old route), so the new route is flown from the decision that asked for
it, whatever the wall time: the offline evaluator's ``--replan on`` does the same.

Missions come from the navigator (``mission``, latched): a new id is followed from its first decision
(the route tracker starts at the pose of that decision, as the simulator's judge does); the same id
with new waypoints is a replan; CANCELED or an outcome stops the decisions. Setpoints carry the
mission id, and SOURCE_SHIELD when the shield replaced the policy's action. Topic names are relative.
"""
from __future__ import annotations

import json
import math
import time
from collections import OrderedDict

import numpy as np
from cage_planner_msgs.msg import CageMap, HeadingSetpoint, Mission, MissionEvent
from cage_sim.controller import REMEMBERED, ArcController
from cage_sim.driver import DEFAULT_REMEMBERED, Driver, fallback_for
from cage_sim.map_points import MapPoints
from cage_sim.mission import EnvConfig
from cage_sim.nodes.node_common import (VEHICLE_PARAMETERS, check, decision_period_ns, declare, declare_vehicle,
                                        start_only_reason)
from cage_sim.nodes.node_runner import run_node
from cage_sim.ros_convert import EVENT_OUTCOMES, map_to_world, mission_points, odom_pose, stamp_ns, time_msg
from cage_sim.recovery import joining_under_way, remaining_route
from cage_sim.route import REPLAN_DEFAULTS, ReplanWatch, RouteTracker
from cage_sim.scan_check import ScanSpec, scan_problem
from cage_sim.sonar import PROFILE_NAMES, scan_from_laserscan
from cage_sim.watchdog import Silence
from cage_sim.shield import SafetyShield
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import LaserScan

from ..policy import PolicyLoadError, env_config_for, load_policy, paths, shipped_path

# The shield's options that are node parameters: parameter -> (SafetyShield field, name in the log).
SHIELD_OPTIONS = {"stall_recovery": ("recover", "stall recovery"), "goal_search": ("goal_search", "goal search")}
RUNTIME = ("shield", "known_map", *SHIELD_OPTIONS)   # what ``ros2 param set`` may change while the node runs
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def trained_layout(spec: str | None, profile: str | None = None):
    """The observation layout of the policy file's training config (``env_config_for``; no file:
    ``profile``'s shipped driver), or None when the metadata cannot say (``load_policy`` then names
    what is wrong with the file)."""
    try:
        meta = json.loads(paths(spec if spec is not None else shipped_path(profile))[1].read_text())
        return env_config_for(meta).layout if isinstance(meta, dict) else None
    except Exception:   # noqa: BLE001 - any malformed file is load_policy's to report
        return None


class PolicyNode(Node):
    def __init__(self) -> None:
        super().__init__("policy_node")
        self.vehicle = declare_vehicle(self)
        self.p = declare(self, policy="", shield=True, stall_recovery=True, goal_search=True, known_map=True,
                         lockstep=True,
                         scan_timeout=1.0, max_invalid_fraction=0.25,
                         **REPLAN_DEFAULTS, replan_wait=2.0,
                         waypoint_radius=EnvConfig().waypoint_radius,
                         frame_id="map")
        self.p.update(declare(self, sensor_frame_id="base_link", liveness_timeout=2.0, sensor="",
                              remembered_returns=DEFAULT_REMEMBERED))
        self.check_parameters()
        self.scan_timeout_ns = int(round(self.p["scan_timeout"] * 1e9))
        self.last_scan_ns: int | None = None          # sim time of the last scan: the decision watchdog
        self.scans_wall = Silence(self.p["liveness_timeout"])   # wall time: the simulator's liveness
        self.republished_wall = 0.0
        self.missions_seen = 0
        policy, self.source, env = self.load(self.p["policy"])
        self.layout, self.sonar = env.layout, env.sonar    # the policy's own observation and sensor profile
        self.driver = Driver(policy, self.layout, self.vehicle, sonar=self.sonar)
        self.scan_spec = ScanSpec.from_sonar(self.sonar, self.p["sensor_frame_id"], self.p["max_invalid_fraction"])
        self.twists: OrderedDict[int, tuple[float, float]] = OrderedDict()   # DVL: body velocity over ground
        self.last_beam = -math.inf                    # latest beam time of the scan last decided on
        self.last_placed: tuple[float, float, float, float] | None = None   # (t, pose) of that decision
        self.period_ns = decision_period_ns(self.vehicle)
        self.tracker: RouteTracker | None = None
        self.mission_id = 0
        self.route: np.ndarray | None = None     # the mission's route; the tracker starts at its first decision
        self.odoms: OrderedDict[int, tuple[float, float, float]] = OrderedDict()
        self.last_decision: HeadingSetpoint | None = None
        self.last_scan_wall: float | None = None
        self.scan_stale = False
        self.finished = False
        self.replan = ReplanWatch(self.p["replan_after"], self.p["min_progress"], self.p["replan_offset"])
        self.held: tuple[int, tuple[float, float, float], LaserScan, float] | None = None   # decision awaiting a plan
        self.map_points: MapPoints | None = None      # the known map from ``map``: the shield's, the route's

        self.setpoint_pub = self.create_publisher(HeadingSetpoint, "heading_setpoint", 10)
        self.event_pub = self.create_publisher(MissionEvent, "mission_event", 10)
        self.create_subscription(LaserScan, "scan", self.on_scan, qos_profile_sensor_data)
        self.create_subscription(Odometry, "odom", self.on_odom, 10)
        self.create_subscription(Mission, "mission", self.on_mission, LATCHED)
        self.create_subscription(MissionEvent, "mission_event", self.on_event, 10)
        self.create_subscription(CageMap, "map", self.on_map, LATCHED)
        self.create_timer(0.1, self.watch_scans)
        self.add_on_set_parameters_callback(self.on_set_parameters)   # after every declare: rclpy calls it there too

    def on_set_parameters(self, params):
        """``ros2 param set <ns>/policy_node shield false`` (or a ``SHIELD_OPTIONS`` one) takes effect
        at the next decision; the other parameters are read at start only, so changing them at run
        time is refused with the reason."""
        from rcl_interfaces.msg import SetParametersResult
        for prm in params:
            if prm.name in RUNTIME:
                if not isinstance(prm.value, bool):
                    return SetParametersResult(successful=False, reason=f"{prm.name} must be a bool")
            elif prm.name in self.p or prm.name in VEHICLE_PARAMETERS:
                return SetParametersResult(successful=False,
                                           reason=start_only_reason(prm.name))
        for prm in params:
            if prm.name in SHIELD_OPTIONS and prm.value != self.p[prm.name]:
                self.p[prm.name] = prm.value
                field, said = SHIELD_OPTIONS[prm.name]
                if isinstance(self.policy, SafetyShield):
                    setattr(self.policy, field, prm.value)
                self.get_logger().info(f"{said} {'on' if prm.value else 'off'} from the next decision")
            if prm.name == "known_map" and prm.value != self.p["known_map"]:
                self.p["known_map"] = prm.value
                self.driver.known = self.map_points if prm.value else None
                self.get_logger().info(f"known map for the shield {'on' if prm.value else 'off'} from the next decision")
            if prm.name == "shield" and prm.value != self.p["shield"]:
                self.p["shield"] = prm.value
                if self.source == HeadingSetpoint.SOURCE_BASELINE:
                    self.get_logger().info(f"shield {prm.value}: no effect on the classical baseline")
                    continue
                raw = self.policy.policy if isinstance(self.policy, SafetyShield) else self.policy
                self.driver.policy = self.shielded(raw, self.layout) if prm.value else raw
                self.get_logger().info(f"safety shield {'on' if prm.value else 'off'} from the next decision")
        return SetParametersResult(successful=True)

    def shielded(self, policy, layout) -> SafetyShield:
        """``policy`` behind the safety shield with the node's shield parameters (its goal search's
        tables built now, not at the first search)."""
        return SafetyShield(policy, fallback_for(policy, layout, self.vehicle, self.p["remembered_returns"]),
                            **{field: self.p[name] for name, (field, _) in SHIELD_OPTIONS.items()}).prepare()

    def check_parameters(self) -> None:
        """One line naming a bad parameter (exit 2), not a node that misbehaves later."""
        p = self.p
        fin = lambda v: isinstance(v, (int, float)) and math.isfinite(v)  # noqa: E731
        check("scan_timeout", p["scan_timeout"], fin(p["scan_timeout"]) and 0 < p["scan_timeout"] <= 60,
              "in (0, 60] sim seconds")
        check("max_invalid_fraction", p["max_invalid_fraction"],
              fin(p["max_invalid_fraction"]) and 0 <= p["max_invalid_fraction"] <= 1, "in [0, 1]")
        check("replan_after", p["replan_after"], isinstance(p["replan_after"], int) and p["replan_after"] >= 1,
              "an integer >= 1")
        check("min_progress", p["min_progress"], fin(p["min_progress"]) and p["min_progress"] >= 0, ">= 0")
        check("replan_offset", p["replan_offset"], fin(p["replan_offset"]) and p["replan_offset"] >= 0,
              ">= 0 m (0: never for being off the route)")
        check("replan_wait", p["replan_wait"], fin(p["replan_wait"]) and 0 < p["replan_wait"] <= 60,
              "in (0, 60] wall seconds")
        check("waypoint_radius", p["waypoint_radius"], fin(p["waypoint_radius"]) and p["waypoint_radius"] > 0, "> 0")
        check("remembered_returns", p["remembered_returns"], p["remembered_returns"] in REMEMBERED,
              f"one of {', '.join(REMEMBERED)}")
        check("liveness_timeout", p["liveness_timeout"], fin(p["liveness_timeout"]) and p["liveness_timeout"] > 0,
              "> 0 s")

    @property
    def policy(self):
        return self.driver.policy

    def load(self, spec: str):
        """(driver policy, setpoint source, EnvConfig): the policy's own sensor and observation layout
        (``env_config_for``); ``sensor`` must name the policy's profile (else one line, exit 2)."""
        sensor = self.p["sensor"] or None
        if sensor is not None and sensor not in PROFILE_NAMES:
            check("sensor", sensor, False, f"one of {', '.join(PROFILE_NAMES)} (or empty: the policy's)")
        if spec == "baseline":
            env = EnvConfig(vehicle=self.vehicle, sonar=sensor or "study")
            self.get_logger().info(f"driving with the classical baseline (ArcController), sensor {env.sonar.profile!r}")
            return ArcController(env.layout, self.vehicle, remembered=self.p["remembered_returns"]), \
                HeadingSetpoint.SOURCE_BASELINE, env
        try:
            # the layout the policy's training config builds, so a file whose recorded layout differs
            # from it is refused naming the field (not by an opaque network size)
            pol = load_policy(spec or None, trained_layout(spec or None, sensor), self.vehicle, profile=sensor)
            env = env_config_for(pol.metadata)
        except PolicyLoadError as err:
            raise ValueError(str(err)) from None
        except (AttributeError, KeyError, TypeError, IndexError) as err:   # a metadata field of the wrong shape
            raise ValueError(f"policy {spec or 'shipped'}: malformed metadata ({type(err).__name__}: {err})") from None
        rates = pol.metadata.get("evaluation", {}).get("rates", {})
        self.get_logger().info(f"policy {pol.path} loaded (sensor {pol.profile!r}, trained on beams "
                               f"{math.degrees(env.sonar.beam_width):g} deg wide, layout "
                               f"{pol.layout.to_dict().get('name')}; training evaluation: {rates}); "
                               f"safety shield {'on' if self.p['shield'] else 'off'}")
        if self.p["shield"]:
            return self.shielded(pol, pol.layout), HeadingSetpoint.SOURCE_POLICY, env
        return pol, HeadingSetpoint.SOURCE_POLICY, env

    # --- inputs ----------------------------------------------------------------------------
    def on_odom(self, msg: Odometry) -> None:
        t_ns, pose = stamp_ns(msg.header.stamp), odom_pose(msg)
        if t_ns < 0 or not all(math.isfinite(v) for v in pose):
            self.get_logger().warning("ignoring odometry with a negative stamp or a non-finite pose",
                                      throttle_duration_sec=5.0)
            return
        self.odoms[t_ns] = pose
        self.twists[t_ns] = (float(msg.twist.twist.linear.x), float(msg.twist.twist.linear.y))
        for recent in (self.odoms, self.twists):     # the last 64 stamps of each
            while len(recent) > 64:
                recent.popitem(last=False)
        self.watch_scans_sim(t_ns, pose)

    def watch_scans_sim(self, t_ns: int, pose) -> None:
        """The clock runs but the scans stopped (simulator dead or paused): hold station within
        ``scan_timeout`` *sim* seconds, whatever the time scale."""
        if (self.finished or self.tracker is None or self.last_scan_ns is None or self.scan_stale
                or t_ns - self.last_scan_ns <= self.scan_timeout_ns):
            return
        self.scan_stale = True
        self.failsafe(t_ns, pose, f"no scan for {(t_ns - self.last_scan_ns) / 1e9:.1f} s of sim time")

    def on_map(self, msg: CageMap) -> None:
        """The known map (latched, from the simulator or a survey): the shield keeps clear of its
        obstacles and net circle beside the sonar's returns (``known_map``), and the route tracker
        flies straight to a goal in sight across it (whatever ``known_map`` says: the simulator's
        judge does). A bad map is refused, logged, and the last good one (or none) kept."""
        try:
            frame = msg.header.frame_id
            if frame and frame != self.p["frame_id"]:
                raise ValueError(f"frame {frame!r}, not the odometry's {self.p['frame_id']!r} (frame_id)")
            points = MapPoints.from_world(map_to_world(msg))
        except ValueError as err:
            self.get_logger().error(f"map refused ({err}); the shield keeps to "
                                    f"{'the last map and ' if self.map_points is not None else ''}the sonar's returns")
            return
        self.map_points = points
        if self.tracker is not None:   # the route's goal in sight (route.RouteTracker), as the simulator's judge
            self.tracker.known = points
        if self.p["known_map"]:
            self.driver.known = points
        self.get_logger().info(f"known map: net radius {msg.net_radius:g} m, {len(msg.obstacles)} obstacles "
                               f"({len(points)} points); the shield keeps clear of it"
                               f"{'' if self.p['known_map'] else ' once known_map is on'}"
                               f"{' (no effect on the classical baseline)' if self.source == HeadingSetpoint.SOURCE_BASELINE else ''}")

    def on_mission(self, msg: Mission) -> None:
        held, self.held = self.held, None      # a new plan, a new mission or a cancel: no longer waiting
        self.on_mission_msg(msg)
        if held is not None and not self.finished and msg.id == self.mission_id and self.tracker is not None:
            self.decide(*held[:3], watch=False)   # the held decision, with the new route

    def on_mission_msg(self, msg: Mission) -> None:
        if msg.state == Mission.CANCELED:
            if msg.id >= self.mission_id and not self.finished:
                self.finished = True
                self.get_logger().info(f"mission {msg.id} canceled: no more decisions")
            return
        pts = mission_points(msg)
        if len(pts) == 0 or not np.isfinite(pts).all():
            # a failed (re)plan: fly nothing rather than the old route (the vehicle holds station)
            if msg.id >= self.mission_id and not self.finished:
                self.mission_id, self.finished = msg.id, True
                self.get_logger().warning(f"mission {msg.id}: empty or non-finite route: no more decisions")
            return
        if msg.id != self.mission_id:
            self.missions_seen += 1
        self.replan.reset()
        if msg.id != self.mission_id:
            self.mission_id, self.route, self.tracker = msg.id, pts, None
            self.finished, self.last_decision = False, None
            self.get_logger().info(f"mission {msg.id}: following a route of {len(pts)} waypoints")
        elif not self.finished:
            start = next(reversed(self.odoms.values())) if self.odoms else pts[0]
            self.route, self.tracker = pts, RouteTracker(start[:2], pts, self.p["waypoint_radius"], self.map_points)
            self.get_logger().info(f"mission {msg.id}: following a new plan of {len(pts)} waypoints "
                                   f"({self.tracker.length:.1f} m)")

    def on_event(self, msg: MissionEvent) -> None:
        if msg.event in EVENT_OUTCOMES and msg.mission_id == self.mission_id and not self.finished:
            self.finished = True
            if isinstance(self.policy, SafetyShield):
                self.get_logger().info(f"mission {msg.mission_id} over: the shield overrode {self.policy.interventions} "
                                       f"of {self.policy.decisions} decisions so far ({self.policy.approaches} "
                                       f"goal approaches (orbit guard, sure approach or goal search), "
                                       f"{self.policy.recoveries} decisions flown by the "
                                       "controller for a policy making no progress)")

    def on_scan(self, msg: LaserScan) -> None:
        self.last_scan_wall = time.monotonic()
        if self.scans_wall.heard(self.last_scan_wall):
            self.get_logger().info("the simulator's scans are back")
        # the decision the scan is for: a mechanical head's sweep is stamped at its oldest beam, which
        # lies before t = 0 for the sweep the head filled while the vehicle waited at the start
        t_ns = self.decision_stamp(stamp_ns(msg.header.stamp), msg)
        if t_ns < 0:
            self.get_logger().warning("ignoring a scan with a negative stamp", throttle_duration_sec=5.0)
            return
        self.last_scan_ns = t_ns if self.last_scan_ns is None else max(self.last_scan_ns, t_ns)
        if self.scan_stale:
            self.scan_stale = False
            self.get_logger().info("scans are back")
        if self.finished or self.route is None:
            return
        if self.last_decision is not None and stamp_ns(self.last_decision.header.stamp) == t_ns:
            if self.last_scan_wall - self.republished_wall > 0.05:   # a flood of repeats is not re-sent
                self.republished_wall = self.last_scan_wall
                self.setpoint_pub.publish(self.last_decision)   # the vehicle may not have had it yet
            return
        if self.p["lockstep"]:
            if t_ns % self.period_ns:
                return
            pose = self.odoms.get(t_ns)
        else:
            last = stamp_ns(self.last_decision.header.stamp) if self.last_decision else -self.period_ns
            if t_ns - last < self.period_ns:
                return
            pose = next(reversed(self.odoms.values())) if self.odoms else None
        if pose is None:
            return  # the pose for this scan has not arrived; the vehicle republishes it while it waits
        problem = scan_problem(self.scan_spec, msg.header.frame_id, msg.angle_min, msg.angle_increment, msg.ranges)
        if problem is not None:
            self.failsafe(t_ns, pose, problem)   # a rotated or foreign scan is never used
            return
        self.decide(t_ns, pose, msg)

    def decision_stamp(self, t_ns: int, msg: LaserScan) -> int:
        """The sim time the scan is for: its stamp (REP 117: the first beam), or for a mechanical head
        (published oldest beam first) the decision at which its latest beam fired."""
        if not self.sonar.mechanical or not math.isfinite(msg.time_increment) or msg.time_increment <= 0:
            return t_ns
        last = t_ns + int(round((len(msg.ranges) - 1) * msg.time_increment * 1e9))
        # the decision at or just after the latest beam, within 1 us either side: the stamp and
        # time_increment round to whole ns (the first sweep's ended 1 ns after t = 0)
        boundary = -(-(last - 1_000) // self.period_ns) * self.period_ns
        return boundary if boundary - last <= int(2 * msg.time_increment * 1e9) + 1_000_000 else last

    # --- decision --------------------------------------------------------------------------
    def scan_problem(self, ranges: np.ndarray) -> str | None:
        if ranges.shape != (self.sonar.n_beams,):
            return f"scan has {ranges.size} ranges, the policy needs {self.sonar.n_beams}"
        invalid = np.isnan(ranges) | (ranges < 0)
        if invalid.mean() > self.p["max_invalid_fraction"]:
            return f"{int(invalid.sum())} of {ranges.size} ranges are invalid (NaN or negative)"
        if invalid.any():
            self.get_logger().warning(f"{int(invalid.sum())} invalid ranges read as 'no return'",
                                      throttle_duration_sec=5.0)
        return None

    def decide(self, t_ns: int, pose: tuple[float, float, float], msg: LaserScan, watch: bool = True) -> None:
        """One decision from the scan for ``t_ns`` at ``pose``. ``watch``: let the replan watch see this
        pose first (off for a decision held for a new plan: the watch saw it when it asked)."""
        if self.held is not None:
            return   # waiting for the plan the held decision asked for
        x, y, yaw = pose
        ranges = np.asarray(msg.ranges, dtype=np.float64)
        problem = self.scan_problem(ranges)
        if problem is not None:
            self.failsafe(t_ns, pose, problem)
            return
        ranges = np.where(ranges < 0, np.nan, ranges)
        if self.tracker is None:   # the mission's first decision: the route starts here
            route = self.route
            if joining_under_way(self.missions_seen == 1, t_ns):   # restarted mid-mission: not back to its start
                route = remaining_route(route, (x, y))
                self.get_logger().info(f"mission {self.mission_id}: joined under way at t={t_ns / 1e9:.1f} s, "
                                       f"{len(route)} of {len(self.route)} waypoints ahead")
            self.tracker = RouteTracker((x, y), route, self.p["waypoint_radius"], self.map_points)
            self.driver.reset()                    # memory and return motion start with the mission
            self.last_beam = -math.inf
            self.last_placed = None
            self.get_logger().info(f"mission {self.mission_id}: first decision at t={t_ns / 1e9:.1f} s, "
                                   f"route {self.tracker.length:.1f} m")
        sighted = self.tracker.sighted
        self.tracker.advance(x, y)
        if self.tracker.sighted and not sighted:
            self.get_logger().info(f"mission {self.mission_id}: goal in sight {self.tracker.remaining(x, y):.1f} m "
                                   "off, the way clear of the known map: flying straight to it")
        if watch and self.watch_progress(t_ns, pose) and self.p["lockstep"]:
            self.held = (t_ns, pose, msg, time.monotonic() + self.p["replan_wait"])
            return
        dist, _ = self.tracker.waypoint(x, y, yaw)
        try:
            # a mechanical head's new beams fired along the way from the previous decision's pose
            placed = (t_ns / 1e9, x, y, yaw)
            track = (self.last_placed, placed) if self.sonar.mechanical and self.last_placed else None
            scan = scan_from_laserscan(ranges, msg.angle_min, msg.angle_increment, stamp_ns(msg.header.stamp) / 1e9,
                                       msg.time_increment if self.sonar.mechanical else 0.0, self.sonar, pose,
                                       self.last_beam, track)
        except ValueError as err:
            self.failsafe(t_ns, pose, str(err))
            return
        self.last_beam, self.last_placed = max(self.last_beam, float(scan.stamps.max())), placed
        action, shielded = self.driver.decide(scan, pose, t_ns / 1e9, self.dvl(t_ns), self.tracker)
        source = HeadingSetpoint.SOURCE_SHIELD if shielded else self.source
        self.publish_setpoint(t_ns, yaw + action * self.vehicle.max_turn, self.vehicle.speed, source)
        self.get_logger().debug(f"decision {t_ns // self.period_ns}: action {action:+.3f}"
                                f"{' (shield)' if shielded else ''}, waypoint {dist:.1f} m")

    def dvl(self, t_ns: int) -> tuple[float, float] | None:
        """The odometry twist at ``t_ns`` as the DVL's body-frame velocity over ground; None when there
        is none or it is exactly zero (a source that leaves the twist unset, or a vehicle holding
        station): the driver then assumes no drift instead of a vehicle "drifting" backwards at its speed."""
        v = self.twists.get(t_ns)
        if v is None or v == (0.0, 0.0) or not all(math.isfinite(c) for c in v):
            return None
        return v

    def publish_setpoint(self, t_ns: int, heading: float, speed: float, source: int) -> None:
        sp = HeadingSetpoint(heading=float(math.atan2(math.sin(heading), math.cos(heading))), speed=float(speed),
                             decision=int(t_ns // self.period_ns), source=source, mission_id=self.mission_id)
        sp.header.stamp, sp.header.frame_id = time_msg(t_ns), self.p["frame_id"]
        self.setpoint_pub.publish(sp)
        self.last_decision = sp

    def failsafe(self, t_ns: int, pose, reason: str) -> None:
        self.get_logger().error(f"failsafe: {reason}: holding station", throttle_duration_sec=2.0)
        self.publish_setpoint(t_ns, pose[2], 0.0, HeadingSetpoint.SOURCE_FAILSAFE)
        self.event(MissionEvent.FAILSAFE, f"policy: {reason}", t_ns, pose)

    def watch_progress(self, t_ns: int, pose) -> bool:
        """Let the replan watch see this decision's pose; True when it asked for a new plan."""
        reason = self.replan.update(self.tracker, pose[0], pose[1])
        if reason is not None:
            self.get_logger().warning(f"mission {self.mission_id}: {reason}: asking for a new plan")
            self.event(MissionEvent.REPLAN_REQUESTED, f"policy: {reason}", t_ns, pose)
        return reason is not None

    def watch_scans(self) -> None:
        """Liveliness in wall time: with the clock standing (lockstep) no sim time passes, so a dead
        simulator is only noticed this way; said once (the vehicle is not moving). A decision held
        for a plan that has not come within ``replan_wait`` is made with the old route."""
        if self.held is not None and time.monotonic() > self.held[3]:
            held, self.held = self.held, None
            self.get_logger().warning(f"mission {self.mission_id}: no new plan within {self.p['replan_wait']:.1f} s: "
                                      "flying on with the old route")
            self.decide(*held[:3], watch=False)
        silent = self.scans_wall.check(time.monotonic())
        if silent is not None and not self.finished and self.tracker is not None:
            self.get_logger().warning(f"no scan for {silent:.1f} s (wall): the simulator is silent")

    def event(self, code: int, detail: str, t_ns: int, pose) -> None:
        ev = MissionEvent(event=code, detail=detail, step=int(t_ns // self.period_ns), mission_id=self.mission_id)
        ev.header.stamp, ev.header.frame_id = time_msg(t_ns), self.p["frame_id"]
        ev.position.x, ev.position.y = float(pose[0]), float(pose[1])
        self.event_pub.publish(ev)


def main(args=None) -> None:
    run_node(PolicyNode, args)


if __name__ == "__main__":
    main()
