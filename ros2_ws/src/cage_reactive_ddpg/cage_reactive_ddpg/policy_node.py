"""policy_node: scan + pose + plan -> next waypoint -> heading setpoint, one decision per metre.

Builds the observation with the same layout, route tracker and vehicle facts as the offline env, and
asks the same policy (the shipped DDPG weights by default, a file from the ``policy`` parameter, or
``baseline`` for the classical controller), so a seeded mission ends in the graph as it does offline.
A learned policy runs behind the safety shield (``cage_sim.shield``; parameter ``shield``, default
on), as it does in the evaluator by default.

Safety: weights that do not match this build are refused at start (exit 2, naming the mismatch).
A scan of the wrong size, or with too many invalid (NaN / negative) ranges, gets a failsafe
setpoint (hold station) and a FAILSAFE mission event instead of a decision; scans that stop coming
are reported the same way. With no progress along the route for ``replan_after`` decisions the node
asks the global planner for a new plan (REPLAN_REQUESTED on /cage/mission_event).
"""
from __future__ import annotations

import math
import time
from collections import OrderedDict

import numpy as np
from cage_planner_msgs.msg import HeadingSetpoint, MissionEvent
from cage_sim.controller import ArcController
from cage_sim.mission import EnvConfig
from cage_sim.node_common import decision_period_ns, declare, declare_vehicle
from cage_sim.node_runner import run_node
from cage_sim.ros_convert import EVENT_OUTCOMES, odom_pose, path_points, stamp_ns, time_msg
from cage_sim.route import RouteTracker
from cage_sim.shield import SafetyShield
from nav_msgs.msg import Odometry, Path
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import LaserScan

from .policy import PolicyLoadError, load_policy

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


class PolicyNode(Node):
    def __init__(self) -> None:
        super().__init__("policy_node")
        self.vehicle = declare_vehicle(self)
        self.p = declare(self, policy="", shield=True, lockstep=True, scan_timeout=1.0, max_invalid_fraction=0.25,
                         replan_after=40, min_progress=2.0, waypoint_radius=EnvConfig().waypoint_radius,
                         frame_id="map")
        self.layout = EnvConfig().layout
        self.policy, self.source = self.load(self.p["policy"])
        self.period_ns = decision_period_ns(self.vehicle)
        self.tracker: RouteTracker | None = None
        self.odoms: OrderedDict[int, tuple[float, float, float]] = OrderedDict()
        self.last_decision: HeadingSetpoint | None = None
        self.last_scan_wall: float | None = None
        self.scan_stale = False
        self.finished = False
        self.best_remaining, self.since_progress = math.inf, 0

        self.setpoint_pub = self.create_publisher(HeadingSetpoint, "/cage/heading_setpoint", 10)
        self.event_pub = self.create_publisher(MissionEvent, "/cage/mission_event", 10)
        self.create_subscription(LaserScan, "/cage/scan", self.on_scan, qos_profile_sensor_data)
        self.create_subscription(Odometry, "/cage/odom", self.on_odom, 10)
        self.create_subscription(Path, "/cage/plan", self.on_plan, LATCHED)
        self.create_subscription(MissionEvent, "/cage/mission_event", self.on_event, 10)
        self.create_timer(0.1, self.watch_scans)

    def load(self, spec: str):
        if spec == "baseline":
            self.get_logger().info("driving with the classical baseline (ArcController)")
            return ArcController(self.layout, self.vehicle), HeadingSetpoint.SOURCE_BASELINE
        try:
            pol = load_policy(spec or None, self.layout, self.vehicle)
        except PolicyLoadError as err:
            raise ValueError(str(err)) from None
        rates = pol.metadata.get("evaluation", {}).get("rates", {})
        self.get_logger().info(f"policy {pol.path} loaded (training evaluation: {rates}); "
                               f"safety shield {'on' if self.p['shield'] else 'off'}")
        if self.p["shield"]:
            return SafetyShield(pol, ArcController(self.layout, self.vehicle)), HeadingSetpoint.SOURCE_POLICY
        return pol, HeadingSetpoint.SOURCE_POLICY

    # --- inputs ----------------------------------------------------------------------------
    def on_odom(self, msg: Odometry) -> None:
        self.odoms[stamp_ns(msg.header.stamp)] = odom_pose(msg)
        while len(self.odoms) > 64:
            self.odoms.popitem(last=False)

    def on_plan(self, msg: Path) -> None:
        pts = path_points(msg)
        if len(pts) == 0 or not np.isfinite(pts).all():
            self.get_logger().warning("ignoring an empty or non-finite plan")
            return
        start = next(reversed(self.odoms.values())) if self.odoms else pts[0]
        self.tracker = RouteTracker(start[:2], pts, self.p["waypoint_radius"])
        self.best_remaining, self.since_progress = math.inf, 0
        self.get_logger().info(f"following a plan of {len(pts)} waypoints ({self.tracker.length:.1f} m)")

    def on_event(self, msg: MissionEvent) -> None:
        if msg.event in EVENT_OUTCOMES and not self.finished:
            self.finished = True
            if isinstance(self.policy, SafetyShield):
                self.get_logger().info(f"mission over: the shield overrode {self.policy.interventions} of "
                                       f"{self.policy.decisions} decisions")

    def on_scan(self, msg: LaserScan) -> None:
        self.last_scan_wall = time.monotonic()
        if self.scan_stale:
            self.scan_stale = False
            self.get_logger().info("scans are back")
        if self.finished or self.tracker is None:
            return
        t_ns = stamp_ns(msg.header.stamp)
        if self.last_decision is not None and stamp_ns(self.last_decision.header.stamp) == t_ns:
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
        self.decide(t_ns, pose, np.asarray(msg.ranges, dtype=np.float64))

    # --- decision --------------------------------------------------------------------------
    def scan_problem(self, ranges: np.ndarray) -> str | None:
        if ranges.shape != (self.layout.n_beams,):
            return f"scan has {ranges.size} ranges, the policy needs {self.layout.n_beams}"
        invalid = np.isnan(ranges) | (ranges < 0)
        if invalid.mean() > self.p["max_invalid_fraction"]:
            return f"{int(invalid.sum())} of {ranges.size} ranges are invalid (NaN or negative)"
        if invalid.any():
            self.get_logger().warning(f"{int(invalid.sum())} invalid ranges read as 'no return'",
                                      throttle_duration_sec=5.0)
        return None

    def decide(self, t_ns: int, pose: tuple[float, float, float], ranges: np.ndarray) -> None:
        x, y, yaw = pose
        problem = self.scan_problem(ranges)
        if problem is not None:
            self.failsafe(t_ns, pose, problem)
            return
        ranges = np.where(ranges < 0, np.nan, ranges)
        self.tracker.advance(x, y)
        dist, err = self.tracker.waypoint(x, y, yaw)
        obs = self.layout.build(ranges, dist, err)
        action = float(np.clip(np.asarray(self.policy.act(obs)).reshape(-1)[0], -1.0, 1.0))
        self.publish_setpoint(t_ns, yaw + action * self.vehicle.max_turn, self.vehicle.speed, self.source)
        self.watch_progress(t_ns, pose)

    def publish_setpoint(self, t_ns: int, heading: float, speed: float, source: int) -> None:
        sp = HeadingSetpoint(heading=float(math.atan2(math.sin(heading), math.cos(heading))), speed=float(speed),
                             decision=int(t_ns // self.period_ns), source=source)
        sp.header.stamp, sp.header.frame_id = time_msg(t_ns), self.p["frame_id"]
        self.setpoint_pub.publish(sp)
        self.last_decision = sp

    def failsafe(self, t_ns: int, pose, reason: str) -> None:
        self.get_logger().error(f"failsafe: {reason}: holding station", throttle_duration_sec=2.0)
        self.publish_setpoint(t_ns, pose[2], 0.0, HeadingSetpoint.SOURCE_FAILSAFE)
        self.event(MissionEvent.FAILSAFE, f"policy: {reason}", t_ns, pose)

    def watch_progress(self, t_ns: int, pose) -> None:
        remaining = self.tracker.remaining(pose[0], pose[1])
        if remaining < self.best_remaining - self.p["min_progress"]:
            self.best_remaining, self.since_progress = remaining, 0
            return
        self.since_progress += 1
        if self.since_progress >= self.p["replan_after"]:
            self.since_progress = 0
            self.best_remaining = remaining
            self.get_logger().warning(f"no progress for {self.p['replan_after']} decisions: asking for a new plan")
            self.event(MissionEvent.REPLAN_REQUESTED, "policy: no progress along the route", t_ns, pose)

    def watch_scans(self) -> None:
        if self.finished or self.tracker is None or self.last_scan_wall is None or self.scan_stale:
            return
        age = time.monotonic() - self.last_scan_wall
        if age > self.p["scan_timeout"]:
            self.scan_stale = True
            t_ns, pose = next(reversed(self.odoms.items())) if self.odoms else (0, (0.0, 0.0, 0.0))
            self.failsafe(t_ns, pose, f"no scan for {age:.1f} s")

    def event(self, code: int, detail: str, t_ns: int, pose) -> None:
        ev = MissionEvent(event=code, detail=detail, step=int(t_ns // self.period_ns))
        ev.header.stamp, ev.header.frame_id = time_msg(t_ns), self.p["frame_id"]
        ev.position.x, ev.position.y = float(pose[0]), float(pose[1])
        self.event_pub.publish(ev)


def main(args=None) -> None:
    run_node(PolicyNode, args)


if __name__ == "__main__":
    main()
