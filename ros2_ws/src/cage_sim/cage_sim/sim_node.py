"""sim_node: the cage world around the vehicle: known map, sonar, obstacle markers, mission judge.

Publishes the known map (/cage/map, latched), a LaserScan (/cage/scan, sensor-data QoS) for every
pose the vehicle node reports, obstacle markers (/cage/obstacles) and the vehicle's track
(/cage/track). When a plan arrives (/cage/plan) the mission starts; at each decision boundary the
pose is judged by the same ``Mission`` the offline env uses, and the outcome (goal, collision, wander,
timeout) goes out on /cage/mission_event. The world and its moving obstacles follow the vehicle
node's simulation clock (odometry stamps), so they stand still while the graph waits.
"""
from __future__ import annotations

import math
from dataclasses import replace

from cage_planner_msgs.msg import CageMap, MissionEvent
from geometry_msgs.msg import Point
from nav_msgs.msg import Odometry, Path
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import LaserScan
from visualization_msgs.msg import Marker, MarkerArray

from .mission import EnvConfig, Mission
from .node_common import decision_period_ns, declare, declare_vehicle
from .node_runner import run_node
from .route import RouteTracker
from .ros_convert import (OUTCOME_EVENTS, odom_pose, path_msg, path_points, scan_msg, stamp_ns, time_msg,
                          world_to_map)
from .scenarios import draw_scenario
from .sonar import SonarModel
from .world import World

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


class SimNode(Node):
    def __init__(self) -> None:
        super().__init__("sim_node")
        vehicle = declare_vehicle(self)
        p = declare(self, scenario="full_cage", seed=0, frame_id="map", sensor_frame_id="base_link",
                    n_beams=72, max_range=20.0, noise_std=0.0, dropout=0.0)
        self.p = p
        self.scenario = draw_scenario(p["scenario"], p["seed"])
        self.world: World = self.scenario.world
        self.sonar = SonarModel(n_beams=p["n_beams"], angle_increment=2 * math.pi / p["n_beams"],
                                max_range=p["max_range"], noise_std=p["noise_std"], dropout=p["dropout"])
        self.config = EnvConfig(vehicle=vehicle, sonar=self.sonar)
        self.period_ns = decision_period_ns(vehicle)
        self.mission: Mission | None = None
        self.last_judged_ns = -1
        self.last_pose: tuple[int, tuple[float, float, float]] | None = None

        self.map_pub = self.create_publisher(CageMap, "/cage/map", LATCHED)
        self.marker_pub = self.create_publisher(MarkerArray, "/cage/obstacles", LATCHED)
        self.scan_pub = self.create_publisher(LaserScan, "/cage/scan", qos_profile_sensor_data)
        self.event_pub = self.create_publisher(MissionEvent, "/cage/mission_event", 10)
        self.track_pub = self.create_publisher(Path, "/cage/track", LATCHED)
        self.create_subscription(Odometry, "/cage/odom", self.on_odom, 10)
        self.create_subscription(Path, "/cage/plan", self.on_plan, LATCHED)

        # Compile (or load from numba's cache) the sonar before anyone waits on a scan.
        self.sonar.scan(self.world, *self.scenario.start)
        self.map_pub.publish(world_to_map(self.world, 0, p["frame_id"]))
        self.marker_pub.publish(self.markers(0))
        self.get_logger().info(
            f"scenario {self.scenario.name!r} (seed {p['seed']}): {len(self.world.known)} known, "
            f"{len(self.world.unknown)} unknown obstacles; goal ({self.scenario.goal[0]:.1f}, "
            f"{self.scenario.goal[1]:.1f})")

    def on_plan(self, msg: Path) -> None:
        pts = path_points(msg)
        if len(pts) == 0:
            self.get_logger().warning("empty plan: ignored")
            return
        if self.mission is not None and self.mission.outcome is not None:
            return
        if self.mission is None:
            start = self.last_pose[1] if self.last_pose else self.scenario.start
            sc = self.scenario.with_waypoints(pts)
            self.mission = Mission(replace(sc, start=start), self.config)
            self.get_logger().info(f"mission started: {len(pts)} waypoints, route {self.mission.route_length:.1f} m")
        else:
            m = self.mission
            m.tracker = RouteTracker((m.x, m.y), pts, self.config.waypoint_radius)
            m.route = m.tracker.route
            self.get_logger().info(f"replanned: {len(pts)} waypoints")

    def on_odom(self, msg: Odometry) -> None:
        t_ns = stamp_ns(msg.header.stamp)
        pose = odom_pose(msg)
        self.last_pose = (t_ns, pose)
        t = t_ns / 1e9
        if self.world.has_moving:
            self.marker_pub.publish(self.markers(t_ns))
        ranges = self.sonar.scan(self.world, *pose, t)
        self.scan_pub.publish(scan_msg(ranges, self.sonar, t_ns, self.p["sensor_frame_id"]))
        if t_ns % self.period_ns == 0 and t_ns > self.last_judged_ns:
            self.last_judged_ns = t_ns
            self.judge(t_ns, pose)

    def judge(self, t_ns: int, pose: tuple[float, float, float]) -> None:
        m = self.mission
        if m is None or m.outcome is not None or t_ns == 0:
            return
        expected = m.steps + 1
        if t_ns // self.period_ns != expected:
            self.get_logger().warning(f"pose for decision {t_ns // self.period_ns}, expected {expected}")
        _, outcome = m.record(*pose)
        self.track_pub.publish(path_msg(m.track, t_ns, self.p["frame_id"]))
        if outcome is not None:
            ev = MissionEvent(event=OUTCOME_EVENTS[outcome], step=m.steps,
                              detail=f"{outcome} after {m.steps} decisions, {m.travelled:.1f} m travelled")
            ev.header.stamp, ev.header.frame_id = time_msg(t_ns), self.p["frame_id"]
            ev.position.x, ev.position.y = pose[0], pose[1]
            self.event_pub.publish(ev)
            self.get_logger().info(f"mission outcome: {ev.detail}")

    def markers(self, t_ns: int) -> MarkerArray:
        out, t = [], t_ns / 1e9
        net = Marker(ns="net", id=0, type=Marker.LINE_STRIP, action=Marker.ADD)
        net.scale.x = 0.2
        net.color.b, net.color.a = 0.8, 1.0
        n = 90
        for i in range(n + 1):
            a = 2 * math.pi * i / n
            net.points.append(Point(x=self.world.net_radius * math.cos(a), y=self.world.net_radius * math.sin(a)))
        out.append(net)
        for group, known in ((self.world.known, True), (self.world.unknown, False)):
            for i, ob in enumerate(group):
                m = Marker(ns="known" if known else "unknown", id=i, action=Marker.ADD,
                           type=Marker.CUBE if ob.shape == "square" else Marker.CYLINDER)
                m.pose.position.x, m.pose.position.y = ob.centre(t)
                m.pose.orientation.w = 1.0
                side = ob.size if ob.shape == "square" else 2 * ob.size
                m.scale.x, m.scale.y, m.scale.z = side, side, 1.0
                m.color.r, m.color.g, m.color.b, m.color.a = (0.4, 0.4, 0.4, 1.0) if known else (0.6, 0.35, 0.2, 1.0)
                out.append(m)
        for m in out:
            m.header.stamp, m.header.frame_id = time_msg(t_ns), self.p["frame_id"]
        return MarkerArray(markers=out)


def main(args=None) -> None:
    run_node(SimNode, args)


if __name__ == "__main__":
    main()
