"""vehicle_node: integrates the heading setpoint with the continuous vehicle model.

Publishes the pose as nav_msgs/Odometry (``odom``) and TF map -> base_link, stamped with
simulation time (topic names are relative, so ``__ns:=/auv1`` moves the vehicle). It owns the simulation clock: ``time_scale`` sim seconds pass per wall second,
and publishes it on ``/clock`` (rosgraph_msgs/Clock, with every pose; ``publish_clock``), so RViz,
rosbag and any node run with ``use_sim_time:=true`` follow sim time as they would a simulator's.

Lockstep (default): at each decision boundary (every step_length / speed sim seconds) the clock
stops until the setpoint for that boundary arrives (HeadingSetpoint stamped with it), so the graph
is deterministic and reproduces the offline env decision by decision, at any time scale. Until the
first setpoint the vehicle holds station at the start with the clock at zero, republishing its pose
for late joiners. A vehicle that waits longer than ``liveness_timeout`` wall seconds (the clock stands,
so only wall time passes) says so once on ``mission_event`` (FAILSAFE) and keeps holding.

Free-run: the latest setpoint is flown while the clock runs. The watchdog is the vehicle's own and
does not trust the policy: a setpoint is valid for one decision period plus ``setpoint_timeout`` *sim*
seconds after its stamp, so at any time scale the vehicle holds station (speed 0, heading kept) at
most ``setpoint_timeout`` sim seconds after the next decision was due, says so once, and resumes when
fresh setpoints come back. While it holds, the clock stands (as in lockstep) and the pose is
republished, so a restarted node finds the mission where it was, not run down by the judge's timeout. A setpoint with speed 0 (the policy's failsafe)
also holds station: position kept against the current, not a drift.

Restart: a new vehicle node first listens ``resume_wait`` wall seconds for the simulator's latched
track (``track``); if a mission is under way it resumes from the last judged pose and sim time
instead of jumping back to the scenario start with the clock at zero.
"""
from __future__ import annotations

import math
import time

from cage_planner_msgs.msg import HeadingSetpoint, Mission, MissionEvent
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry, Path
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from tf2_msgs.msg import TFMessage

from .node_common import check, decision_period_ns, declare, declare_vehicle
from .node_runner import run_node
from ..ros_convert import EVENT_OUTCOMES, quaternion_to_yaw, stamp_ns, time_msg, yaw_to_quaternion
from ..scenarios import draw_scenario
from ..vehicle import advance, velocity_over_ground
from ..watchdog import Silence

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
CLOCK_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)   # matches rclpy's best-effort TimeSource too


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and math.isfinite(v)


class VehicleNode(Node):
    def __init__(self) -> None:
        super().__init__("vehicle_node")
        self.vehicle = declare_vehicle(self)
        p = declare(self, scenario="full_cage", seed=0, lockstep=True, time_scale=20.0, substeps=10,
                    setpoint_timeout=0.5, liveness_timeout=2.0, idle_publish_rate=10.0, resume=True,
                    resume_wait=1.0, frame_id="map", child_frame_id="base_link", publish_clock=True)
        check("time_scale", p["time_scale"], _finite(p["time_scale"]) and 0.01 <= p["time_scale"] <= 1000,
              "in [0.01, 1000]")
        check("substeps", p["substeps"], 1 <= p["substeps"] <= 1000, "in [1, 1000]")
        check("setpoint_timeout", p["setpoint_timeout"], _finite(p["setpoint_timeout"]) and
              0 < p["setpoint_timeout"] <= 10, "in (0, 10] sim seconds")
        for name in ("liveness_timeout", "idle_publish_rate"):
            check(name, p[name], _finite(p[name]) and 0 < p[name] <= 1000, "in (0, 1000]")
        check("resume_wait", p["resume_wait"], _finite(p["resume_wait"]) and 0 <= p["resume_wait"] <= 60,
              "in [0, 60] s")
        sc = draw_scenario(p["scenario"], p["seed"])
        self.p = p
        self.x, self.y, self.yaw = sc.start
        self.current = sc.world.current_field
        self.period_ns = decision_period_ns(self.vehicle)
        self.dt_ns = self.period_ns // p["substeps"]
        if self.dt_ns * p["substeps"] != self.period_ns:
            raise ValueError("the decision period must split into whole nanosecond substeps")
        self.valid_ns = self.period_ns + int(round(p["setpoint_timeout"] * 1e9))
        self.t_ns = 0
        self.setpoint: HeadingSetpoint | None = None
        self.waiting = Silence(p["liveness_timeout"])      # lockstep: wall seconds at a boundary
        self.stopped_reason: str | None = None
        self.mission_id = 0
        self.speed_now = 0.0       # through the water, for the odometry's velocity over ground
        self.finished = False
        self.ready = not p["resume"] or p["resume_wait"] == 0
        self.started_wall = time.monotonic()

        self.odom_pub = self.create_publisher(Odometry, "odom", 10)
        self.tf_pub = self.create_publisher(TFMessage, "/tf", 10)
        # /clock is global in ROS (two vehicles in one domain: publish_clock:=false on all but one)
        self.clock_pub = self.create_publisher(Clock, "/clock", CLOCK_QOS) if p["publish_clock"] else None
        self.event_pub = self.create_publisher(MissionEvent, "mission_event", 10)
        self.create_subscription(HeadingSetpoint, "heading_setpoint", self.on_setpoint, 10)
        self.create_subscription(MissionEvent, "mission_event", self.on_event, 10)
        self.create_subscription(Mission, "mission", self.on_mission, LATCHED)
        if not self.ready:
            self.create_subscription(Path, "track", self.on_track, LATCHED)
        self.create_timer(self.dt_ns / 1e9 / p["time_scale"], self.tick)
        self.create_timer(1.0 / p["idle_publish_rate"], self.republish_when_idle)
        self.get_logger().info(
            f"vehicle at ({self.x:.2f}, {self.y:.2f}, {math.degrees(self.yaw):.1f} deg), "
            f"{'lockstep' if p['lockstep'] else 'free-run'}, time scale {p['time_scale']}x")
        if self.ready:
            self.publish_pose()

    # --- start-up / restart ----------------------------------------------------------------
    def on_track(self, msg: Path) -> None:
        """A mission under way (the simulator's latched track): take its last pose and sim time."""
        if self.ready or not msg.poses:
            return
        last = msg.poses[-1].pose
        t_ns = stamp_ns(msg.header.stamp)
        pose = (last.position.x, last.position.y, quaternion_to_yaw(last.orientation))
        if not all(math.isfinite(v) for v in pose) or t_ns < 0 or t_ns % self.period_ns:
            self.get_logger().warning("ignoring a track that is not a judged decision boundary")
            return
        self.x, self.y, self.yaw = pose
        self.t_ns = t_ns
        self.become_ready(f"resumed the mission under way at t={t_ns / 1e9:.1f} s, ({self.x:.2f}, {self.y:.2f})")

    def become_ready(self, why: str) -> None:
        self.ready = True
        self.waiting.heard(time.monotonic())
        self.get_logger().info(why)
        self.publish_pose()

    # --- inputs ----------------------------------------------------------------------------
    def on_setpoint(self, msg: HeadingSetpoint) -> None:
        if not (math.isfinite(msg.heading) and math.isfinite(msg.speed)):
            self.get_logger().warning("ignoring a setpoint with a non-finite heading or speed",
                                      throttle_duration_sec=5.0)
            return
        if msg.mission_id != self.mission_id:
            return  # for another mission (a preempted or canceled one)
        t = stamp_ns(msg.header.stamp)
        if self.p["lockstep"]:
            if t != self.t_ns:
                return  # for another decision: a repeat of an old one, or early
        elif t > self.t_ns or t + self.valid_ns < self.t_ns or (
                self.setpoint is not None and t < stamp_ns(self.setpoint.header.stamp)):
            self.get_logger().warning(f"ignoring a setpoint stamped {t / 1e9:.2f} s at t={self.t_ns / 1e9:.2f} s",
                                      throttle_duration_sec=5.0)
            return
        self.setpoint = msg

    def on_mission(self, msg: Mission) -> None:
        """A new mission id flies again after an outcome; CANCELED of the current (or a newer, failed)
        one holds station. A new mission that finds the vehicle holding mid-decision moves the clock
        (not the vehicle) on to the next decision boundary: holding station takes time, and every
        mission starts on a boundary, where the simulator starts judging it."""
        if msg.state == Mission.CANCELED:
            if msg.id >= self.mission_id and not self.finished:
                self.finished = True
                self.get_logger().info(f"mission {msg.id} canceled: holding station")
        elif msg.id != self.mission_id:
            if self.finished and self.p["lockstep"]:
                self.t_ns = -(-self.t_ns // self.period_ns) * self.period_ns
                self.setpoint = None
            self.mission_id, self.finished = msg.id, False
            self.waiting.heard(time.monotonic())
            self.get_logger().info(f"mission {msg.id}: flying from ({self.x:.2f}, {self.y:.2f}) "
                                   f"at t={self.t_ns / 1e9:.1f} s")
            if self.ready:
                self.publish_pose()

    def on_event(self, msg: MissionEvent) -> None:
        if msg.event in EVENT_OUTCOMES and msg.mission_id == self.mission_id and not self.finished:
            self.finished = True
            self.get_logger().info(f"mission {msg.mission_id} over ({EVENT_OUTCOMES[msg.event]}): holding station")

    # --- clock -----------------------------------------------------------------------------
    def tick(self) -> None:
        if not self.ready:
            if time.monotonic() - self.started_wall >= self.p["resume_wait"]:
                self.become_ready("no mission under way: starting at the scenario start")
            return
        if self.finished:
            return
        sp = self.setpoint
        if self.p["lockstep"]:
            at_boundary = self.t_ns % self.period_ns == 0
            if at_boundary and (sp is None or stamp_ns(sp.header.stamp) != self.t_ns):
                waited = self.waiting.check(time.monotonic())
                if waited is not None and self.t_ns > 0:
                    self.hold(f"no setpoint for {waited:.1f} s (wall) at t={self.t_ns / 1e9:.1f} s")
                return
            self.waiting.heard(time.monotonic())
        elif sp is None:
            return  # the mission has not started: the clock stands at zero
        elif self.t_ns - stamp_ns(sp.header.stamp) > self.valid_ns:
            # hold station with the clock standing, as lockstep does: the mission is not run down by the
            # judge's timeout while a node restarts; the pose is republished so it can decide again
            self.hold(f"no fresh setpoint since t={stamp_ns(sp.header.stamp) / 1e9:.1f} s "
                      f"(now t={self.t_ns / 1e9:.1f} s)")
            return
        self.resume()
        speed = min(max(float(sp.speed), 0.0), self.vehicle.speed)
        self.speed_now = speed
        if speed > 0.0:   # speed 0 is a failsafe "hold station": station keeping, no drift with the current
            # advance: the env's own motion function (exact closed form in a uniform current, substeps in a varying one)
            self.x, self.y, self.yaw = advance(self.x, self.y, self.yaw, sp.heading, self.dt_ns / 1e9, self.vehicle,
                                               self.current, self.t_ns / 1e9, speed)
        self.t_ns += self.dt_ns
        self.publish_pose()

    def hold(self, reason: str) -> None:
        """Say once that the vehicle holds station (the caller keeps it still)."""
        if self.stopped_reason is not None:
            return
        self.stopped_reason = reason
        self.get_logger().warning(f"{reason}: holding station")
        ev = MissionEvent(event=MissionEvent.FAILSAFE, detail=f"vehicle: {reason}", mission_id=self.mission_id,
                          step=int(self.t_ns // self.period_ns))
        ev.header.stamp, ev.header.frame_id = time_msg(self.t_ns), self.p["frame_id"]
        ev.position.x, ev.position.y = float(self.x), float(self.y)
        self.event_pub.publish(ev)

    def resume(self) -> None:
        if self.stopped_reason is not None:
            self.get_logger().info(f"setpoints are back at t={self.t_ns / 1e9:.1f} s: resuming")
            self.stopped_reason = None

    def republish_when_idle(self) -> None:
        """While the clock stands (before the mission, waiting, or after it) late joiners still see us."""
        if not self.ready:
            return
        standing = self.finished or self.stopped_reason is not None or (
            self.t_ns % self.period_ns == 0 and (self.p["lockstep"] or self.setpoint is None))
        if standing:
            self.publish_pose()

    # --- outputs ---------------------------------------------------------------------------
    def publish_pose(self) -> None:
        stamp = time_msg(self.t_ns)
        odom = Odometry()
        odom.header.stamp, odom.header.frame_id = stamp, self.p["frame_id"]
        odom.child_frame_id = self.p["child_frame_id"]
        odom.pose.pose.position.x, odom.pose.pose.position.y = float(self.x), float(self.y)
        odom.pose.pose.orientation = yaw_to_quaternion(self.yaw)
        flying = not self.finished and self.stopped_reason is None
        # Before the first setpoint the clock stands and the vehicle flies from this pose at its speed
        # (the offline model has no spin-up), so the DVL reading it reports is that flight's, not "at
        # rest": the policy's shield and baseline see the drift offline does. Also before the mission
        # message has arrived: every odometry at the start's stamp then carries the same twist, so the
        # first decision does not depend on which of them reached the policy first (it did: a 1 cm
        # graph-vs-offline difference in 1 of ~4 runs).
        speed = self.speed_now if self.setpoint is not None else self.vehicle.speed
        if flying and speed > 0:   # twist: velocity over ground in the body frame (REP 105), as a DVL
            v = velocity_over_ground(self.yaw, speed, self.current.velocity(self.x, self.y, self.t_ns / 1e9))
            odom.twist.twist.linear.x, odom.twist.twist.linear.y = float(v[0]), float(v[1])
        # holding station (or not flying): zero over ground
        self.odom_pub.publish(odom)
        tf = TransformStamped()
        tf.header = odom.header
        tf.child_frame_id = odom.child_frame_id
        tf.transform.translation.x, tf.transform.translation.y = float(self.x), float(self.y)
        tf.transform.rotation = odom.pose.pose.orientation
        self.tf_pub.publish(TFMessage(transforms=[tf]))
        if self.clock_pub is not None:
            self.clock_pub.publish(Clock(clock=stamp))


def main(args=None) -> None:
    run_node(VehicleNode, args)


if __name__ == "__main__":
    main()
