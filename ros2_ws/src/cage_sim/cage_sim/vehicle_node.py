"""vehicle_node: integrates the heading setpoint with the continuous vehicle model.

Publishes the pose as nav_msgs/Odometry (/cage/odom) and TF map -> base_link, stamped with
simulation time. It owns the simulation clock: ``time_scale`` sim seconds pass per wall second.

Lockstep (default): at each decision boundary (every step_length / speed sim seconds) the clock
stops until the setpoint for that boundary arrives (HeadingSetpoint stamped with it), so the graph
is deterministic and reproduces the offline env decision by decision, at any time scale. Until the
first setpoint the vehicle holds station at the start with the clock at zero, republishing its pose
for late joiners. A setpoint that does not come within ``setpoint_timeout`` wall seconds is
stale: the vehicle holds station (speed 0) and says so on /cage/mission_event, then resumes when
setpoints come back. In free-run mode the latest setpoint is used and a stale one also stops it.
"""
from __future__ import annotations

import math
import time

from cage_planner_msgs.msg import HeadingSetpoint, MissionEvent
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from tf2_msgs.msg import TFMessage

from .node_common import decision_period_ns, declare, declare_vehicle
from .node_runner import run_node
from .ros_convert import EVENT_OUTCOMES, stamp_ns, time_msg, yaw_to_quaternion
from .scenarios import draw_scenario
from .vehicle import propagate


class VehicleNode(Node):
    def __init__(self) -> None:
        super().__init__("vehicle_node")
        self.vehicle = declare_vehicle(self)
        p = declare(self, scenario="full_cage", seed=0, lockstep=True, time_scale=20.0, substeps=10,
                    setpoint_timeout=2.0, idle_publish_rate=10.0, frame_id="map", child_frame_id="base_link")
        if p["time_scale"] <= 0 or p["substeps"] < 1 or p["setpoint_timeout"] <= 0:
            raise ValueError("time_scale and setpoint_timeout must be > 0 and substeps >= 1")
        sc = draw_scenario(p["scenario"], p["seed"])
        self.p = p
        self.x, self.y, self.yaw = sc.start
        self.current = sc.world.current
        self.period_ns = decision_period_ns(self.vehicle)
        self.dt_ns = self.period_ns // p["substeps"]
        if self.dt_ns * p["substeps"] != self.period_ns:
            raise ValueError("the decision period must split into whole nanosecond substeps")
        self.t_ns = 0
        self.setpoint: HeadingSetpoint | None = None
        self.setpoint_wall = 0.0
        self.waiting_since = time.monotonic()
        self.stopped_reason: str | None = None
        self.finished = False

        self.odom_pub = self.create_publisher(Odometry, "/cage/odom", 10)
        self.tf_pub = self.create_publisher(TFMessage, "/tf", 10)
        self.event_pub = self.create_publisher(MissionEvent, "/cage/mission_event", 10)
        self.create_subscription(HeadingSetpoint, "/cage/heading_setpoint", self.on_setpoint, 10)
        self.create_subscription(MissionEvent, "/cage/mission_event", self.on_event, 10)
        self.create_timer(self.dt_ns / 1e9 / p["time_scale"], self.tick)
        self.create_timer(1.0 / p["idle_publish_rate"], self.republish_when_idle)
        self.get_logger().info(
            f"vehicle at ({self.x:.2f}, {self.y:.2f}, {math.degrees(self.yaw):.1f} deg), "
            f"{'lockstep' if p['lockstep'] else 'free-run'}, time scale {p['time_scale']}x")
        self.publish_pose()

    # --- inputs ----------------------------------------------------------------------------
    def on_setpoint(self, msg: HeadingSetpoint) -> None:
        if not (math.isfinite(msg.heading) and math.isfinite(msg.speed)):
            self.get_logger().warning("ignoring a setpoint with a non-finite heading or speed")
            return
        if self.p["lockstep"] and stamp_ns(msg.header.stamp) != self.t_ns:
            return  # for another decision: a repeat of an old one, or early
        self.setpoint, self.setpoint_wall = msg, time.monotonic()

    def on_event(self, msg: MissionEvent) -> None:
        if msg.event in EVENT_OUTCOMES and not self.finished:
            self.finished = True
            self.get_logger().info(f"mission over ({EVENT_OUTCOMES[msg.event]}): holding station")

    # --- clock -----------------------------------------------------------------------------
    def tick(self) -> None:
        if self.finished:
            return
        sp = self.setpoint
        stale = sp is None or time.monotonic() - self.setpoint_wall > self.p["setpoint_timeout"]
        at_boundary = self.t_ns % self.period_ns == 0
        if self.p["lockstep"] and at_boundary and (sp is None or stamp_ns(sp.header.stamp) != self.t_ns):
            self.check_stale(started=self.t_ns > 0)
            return
        if not self.p["lockstep"] and stale:
            self.check_stale(started=sp is not None)
            return
        self.resume()
        speed = min(max(float(sp.speed), 0.0), self.vehicle.speed)
        self.x, self.y, self.yaw = propagate(self.x, self.y, self.yaw, sp.heading, self.dt_ns / 1e9,
                                             speed, self.vehicle.max_yaw_rate, self.current)
        self.t_ns += self.dt_ns
        self.publish_pose()

    def check_stale(self, started: bool) -> None:
        waited = time.monotonic() - (self.setpoint_wall if self.setpoint is not None else self.waiting_since)
        if started and waited > self.p["setpoint_timeout"] and self.stopped_reason is None:
            self.stopped_reason = f"no setpoint for {waited:.1f} s at t={self.t_ns / 1e9:.1f} s"
            self.get_logger().warning(f"{self.stopped_reason}: holding station")
            ev = MissionEvent(event=MissionEvent.FAILSAFE, detail=f"vehicle: {self.stopped_reason}")
            ev.header.stamp, ev.header.frame_id = time_msg(self.t_ns), self.p["frame_id"]
            ev.position.x, ev.position.y = float(self.x), float(self.y)
            self.event_pub.publish(ev)

    def resume(self) -> None:
        if self.stopped_reason is not None:
            self.get_logger().info("setpoints are back: resuming")
            self.stopped_reason = None

    def republish_when_idle(self) -> None:
        """While the clock stands (before the mission, waiting, or after it) late joiners still see us."""
        if self.t_ns % self.period_ns == 0 or self.finished or self.stopped_reason:
            self.publish_pose()

    # --- outputs ---------------------------------------------------------------------------
    def publish_pose(self) -> None:
        stamp = time_msg(self.t_ns)
        odom = Odometry()
        odom.header.stamp, odom.header.frame_id = stamp, self.p["frame_id"]
        odom.child_frame_id = self.p["child_frame_id"]
        odom.pose.pose.position.x, odom.pose.pose.position.y = float(self.x), float(self.y)
        odom.pose.pose.orientation = yaw_to_quaternion(self.yaw)
        moving = self.setpoint is not None and not self.finished and self.stopped_reason is None
        odom.twist.twist.linear.x = self.vehicle.speed if moving else 0.0
        self.odom_pub.publish(odom)
        tf = TransformStamped()
        tf.header = odom.header
        tf.child_frame_id = odom.child_frame_id
        tf.transform.translation.x, tf.transform.translation.y = float(self.x), float(self.y)
        tf.transform.rotation = odom.pose.pose.orientation
        self.tf_pub.publish(TFMessage(transforms=[tf]))


def main(args=None) -> None:
    run_node(VehicleNode, args)


if __name__ == "__main__":
    main()
