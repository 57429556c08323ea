"""sim_node: the cage world around the vehicle: known map, sonar, obstacle markers, mission judge.

Publishes the known map (``map``, latched), a LaserScan (``scan``, sensor-data QoS) for every pose
the vehicle node reports, obstacle markers (``obstacles``) and the vehicle's track (``track``); all
names are relative, so ``__ns:=/auv1`` moves the whole vehicle. The navigator's ``mission`` (latched)
says what to judge: a new mission id starts a new ``Mission`` (new route, new judge) at the next
decision boundary, from the pose the vehicle has there; the same id with new waypoints is a replan.
Each decision is judged by the same ``Mission`` code the offline env uses; STARTED, WAYPOINT_REACHED
and the outcome (goal, collision, wander, timeout) go out on ``mission_event`` with the mission id.
The world and its moving obstacles follow the vehicle node's simulation clock (odometry stamps), so
they stand still while the graph waits.

Faults: odometry with a non-finite pose, a negative stamp or a stamp before the last judged decision
is refused (logged, rate-limited); a repeat of the last pose within 50 ms is not rescanned (a flood
costs nothing). Markers are sent in full once (latched) and then only the moving ones, at most
``marker_rate`` times per wall second, so 10,000 obstacles do not cost a MarkerArray per odometry
message. A simulator restarted mid-mission (the first mission it sees, starting after t=0) judges the
rest of the latched route from the vehicle's pose, not a detour back to the mission start.
"""
from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from cage_planner_msgs.msg import CageMap, Mission as MissionMsg, MissionEvent
from geometry_msgs.msg import Point
from nav_msgs.msg import Odometry, Path
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import LaserScan
from visualization_msgs.msg import Marker, MarkerArray

from ..mission import EnvConfig, Mission, new_fish, with_schools
from .node_common import check, decision_period_ns, declare, declare_sensor, declare_vehicle
from .node_runner import run_node
from ..recovery import joining_under_way, remaining_route
from ..ros_convert import (OUTCOME_EVENTS, laserscan_msg, mission_points, odom_pose, path_msg, stamp_ns, time_msg,
                          world_to_map)
from ..scenarios import draw_scenario
from ..sonar import laserscan_fields
from ..watchdog import Silence
from ..world import World

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


class SimNode(Node):
    def __init__(self) -> None:
        super().__init__("sim_node")
        vehicle = declare_vehicle(self)
        p = declare(self, scenario="full_cage", seed=0, frame_id="map", sensor_frame_id="base_link",
                    marker_rate=2.0, liveness_timeout=2.0)
        self.p = p
        self.sonar = declare_sensor(self)          # the profile's beams, timing and noise (+ overrides)
        fin = lambda v: isinstance(v, (int, float)) and math.isfinite(v)  # noqa: E731
        check("marker_rate", p["marker_rate"], fin(p["marker_rate"]) and 0 < p["marker_rate"] <= 100, "in (0, 100] Hz")
        check("liveness_timeout", p["liveness_timeout"], fin(p["liveness_timeout"]) and p["liveness_timeout"] > 0, "> 0 s")
        self.odom_silence = Silence(p["liveness_timeout"])   # the vehicle node's liveliness, in wall time
        self.marker_wall = 0.0
        self.scan_wall = 0.0
        self.started_missions = 0
        self.scenario = draw_scenario(p["scenario"], p["seed"])
        self.world: World = self.scenario.world
        # The schools belong to the water, not to a mission: each mission carries them on from where
        # the last one left them (the first starts them at home, as an offline episode does).
        self.fish = new_fish(self.world)
        self.head = self.sonar.head()              # stateful: a scanning head fires the beams due
        self.rng = np.random.default_rng(p["seed"])   # the sonar's noise, dropout and clutter
        self.config = EnvConfig(vehicle=vehicle, sonar=self.sonar)
        self.period_ns = decision_period_ns(vehicle)
        self.mission: Mission | None = None
        self.mission_id = 0
        self.pending: MissionMsg | None = None     # a new mission, started at the next decision boundary
        self.first_decision = 0                    # decision index of the mission's start
        self.last_judged_ns = -1
        self.last_pose: tuple[int, tuple[float, float, float]] | None = None

        self.map_pub = self.create_publisher(CageMap, "map", LATCHED)
        self.marker_pub = self.create_publisher(MarkerArray, "obstacles", LATCHED)
        self.scan_pub = self.create_publisher(LaserScan, "scan", qos_profile_sensor_data)
        self.event_pub = self.create_publisher(MissionEvent, "mission_event", 10)
        self.track_pub = self.create_publisher(Path, "track", LATCHED)
        self.create_subscription(Odometry, "odom", self.on_odom, 10)
        self.create_timer(0.5, self.watch_odometry)
        self.create_subscription(MissionMsg, "mission", self.on_mission, LATCHED)

        # Compile (or load from numba's cache) the sonar before anyone waits on a scan.
        self.sonar.scan(self.world, *self.scenario.start)
        self.get_logger().info(f"sonar: profile {self.sonar.profile!r}, {self.sonar.n_beams} beams, "
                               f"fov {math.degrees(self.sonar.fov):.0f} deg, beams {math.degrees(self.sonar.beam_width):g} deg wide")
        self.map_pub.publish(world_to_map(self.world, 0, p["frame_id"]))
        self.marker_pub.publish(self.markers(0))
        self.get_logger().info(
            f"scenario {self.scenario.name!r} (seed {p['seed']}): {len(self.world.known)} known, "
            f"{len(self.world.unknown)} unknown obstacles; goal ({self.scenario.goal[0]:.1f}, "
            f"{self.scenario.goal[1]:.1f})")

    def on_mission(self, msg: MissionMsg) -> None:
        if msg.state == MissionMsg.CANCELED:
            if msg.id >= self.mission_id:
                self.get_logger().info(f"mission {msg.id} canceled: no longer judged")
                self.mission, self.pending = None, None
            return
        pts = mission_points(msg)
        if len(pts) == 0 or not np.isfinite(pts).all():
            self.get_logger().warning(f"mission {msg.id}: empty or non-finite route: ignored")
            return
        if msg.id != self.mission_id:
            self.pending = msg
            self.get_logger().debug(f"mission {msg.id}: starts at the next decision boundary")
            if self.last_pose is not None and self.last_pose[0] % self.period_ns == 0:
                self.start_pending(*self.last_pose)
                # the new mission's sonar starts here, as offline: a scanning head left unprimed
                # until the next decision would fill its first sweep there instead of stepping to it
                self.publish_scan(*self.last_pose)
            return
        m = self.mission
        if m is None or m.outcome is not None:
            return
        m.replan(pts)
        self.get_logger().info(f"mission {msg.id} replanned: {len(pts)} waypoints")

    def start_pending(self, t_ns: int, pose: tuple[float, float, float]) -> None:
        """Start the pending mission at a decision boundary, from the pose the vehicle has there."""
        msg, self.pending = self.pending, None
        pts = mission_points(msg)
        self.started_missions += 1
        if joining_under_way(self.started_missions == 1, t_ns):
            # a restarted simulator: judge the rest of the route, not a detour back to the mission start
            pts = remaining_route(pts, pose[:2])
            self.get_logger().info(f"mission {msg.id}: joined under way at t={t_ns / 1e9:.1f} s, "
                                   f"{len(pts)} waypoints ahead")
        sc = replace(self.scenario.with_waypoints(pts), start=pose, goal=(float(pts[-1][0]), float(pts[-1][1])))
        self.mission = Mission(sc, self.config, fish=self.fish)
        self.head = self.sonar.head()   # a new mission's sonar starts afresh, as offline
        self.mission_id = msg.id
        self.first_decision = t_ns // self.period_ns
        self.last_judged_ns = t_ns
        self.get_logger().info(f"mission {msg.id} started: {len(sc.waypoints)} waypoints, "
                               f"route {self.mission.route_length:.1f} m, at t={t_ns / 1e9:.1f} s")
        self.event(MissionEvent.STARTED, f"mission {msg.id}: route {self.mission.route_length:.1f} m", t_ns, pose)

    def event(self, code: int, detail: str, t_ns: int, pose) -> None:
        ev = MissionEvent(event=code, detail=detail, mission_id=self.mission_id,
                          step=self.mission.steps if self.mission else 0)
        ev.header.stamp, ev.header.frame_id = time_msg(t_ns), self.p["frame_id"]
        ev.position.x, ev.position.y = float(pose[0]), float(pose[1])
        self.event_pub.publish(ev)

    def on_odom(self, msg: Odometry) -> None:
        t_ns = stamp_ns(msg.header.stamp)
        pose = odom_pose(msg)
        if t_ns < 0 or not all(math.isfinite(v) for v in pose):
            self.get_logger().warning("ignoring odometry with a negative stamp or a non-finite pose",
                                      throttle_duration_sec=5.0)
            return
        if t_ns < self.last_judged_ns:
            self.get_logger().warning(f"ignoring odometry from the past (t={t_ns / 1e9:.2f} s, judged up to "
                                      f"{self.last_judged_ns / 1e9:.2f} s)", throttle_duration_sec=5.0)
            return
        now = time.monotonic()
        if self.odom_silence.heard(now):
            self.get_logger().info(f"odometry is back at t={t_ns / 1e9:.1f} s")
        if (t_ns, pose) == self.last_pose and now - self.scan_wall < 0.05:
            return   # a repeat (the vehicle waiting, or a flood): it already has its scan
        self.last_pose, self.scan_wall = (t_ns, pose), now
        if (self.world.has_moving or self.fish is not None) and now - self.marker_wall >= 1.0 / self.p["marker_rate"]:
            self.marker_wall = now   # bounded rate, moving ones (and schools) only: 10,000 static markers are sent once
            self.marker_pub.publish(self.markers(t_ns, moving_only=True))
        # judge first, then scan: the scan shows the world (fish) after the decision, as offline
        if t_ns % self.period_ns == 0 and self.pending is not None:
            self.start_pending(t_ns, pose)
        elif t_ns % self.period_ns == 0 and t_ns > self.last_judged_ns:
            self.last_judged_ns = t_ns
            self.judge(t_ns, pose)
        self.publish_scan(t_ns, pose)

    def publish_scan(self, t_ns: int, pose: tuple[float, float, float]) -> None:
        """The profile's scan from ``pose`` (fish where the judge has them), as a REP 117 LaserScan.

        An electronic sonar scans every odometry; a mechanical head steps once per decision, as the
        offline ``Mission.sense`` does (the beams it fires in between come from the pose interpolated
        across the decision), and is republished unchanged between decisions."""
        scene = with_schools(self.world, self.fish)   # the missions fly these very schools (Mission.scene)
        t = t_ns / 1e9
        at_boundary = t_ns % self.period_ns == 0
        if self.head.last is None:
            scan = self.head.reset(scene, *pose, t, self.rng)
        elif self.sonar.mechanical and not (at_boundary and t > float(self.head.last.stamps.max())):
            scan = self.head.last
        else:
            scan = self.head.update(scene, *pose, t, self.rng)
        self.scan_pub.publish(laserscan_msg(laserscan_fields(scan, self.sonar), self.p["sensor_frame_id"]))

    def judge(self, t_ns: int, pose: tuple[float, float, float]) -> None:
        m = self.mission
        if m is None or m.outcome is not None:
            return
        expected = self.first_decision + m.steps + 1
        if t_ns // self.period_ns != expected:
            self.get_logger().warning(f"pose for decision {t_ns // self.period_ns}, expected {expected}")
        index = m.index
        _, outcome = m.record(*pose)
        self.track_pub.publish(path_msg(m.track, t_ns, self.p["frame_id"]))
        if m.index != index and outcome is None:
            self.event(MissionEvent.WAYPOINT_REACHED, f"waypoint {index + 1} of {len(m.route)} reached", t_ns, pose)
        if outcome is not None:
            detail = f"{outcome} after {m.steps} decisions, {m.travelled:.1f} m travelled"
            self.event(OUTCOME_EVENTS[outcome], detail, t_ns, pose)
            self.get_logger().info(f"mission {self.mission_id} outcome: {detail}")
        else:
            self.get_logger().debug(f"decision {m.steps}: ({pose[0]:.2f}, {pose[1]:.2f}), "
                                    f"{m.remaining:.1f} m to go")

    def watch_odometry(self) -> None:
        """Say once when the vehicle node falls silent (dead or paused: the clock stands, nothing to judge)."""
        silent = self.odom_silence.check(time.monotonic())
        if silent is not None:
            self.get_logger().warning(f"no odometry for {silent:.1f} s: the vehicle node is silent")

    def markers(self, t_ns: int, moving_only: bool = False) -> MarkerArray:
        out, t = [], t_ns / 1e9
        net = Marker(ns="net", id=0, type=Marker.LINE_STRIP, action=Marker.ADD)
        net.scale.x = 0.2
        net.color.b, net.color.a = 0.8, 1.0
        n = 90
        for i in range(n + 1):
            a = 2 * math.pi * i / n
            net.points.append(Point(x=self.world.net_radius * math.cos(a), y=self.world.net_radius * math.sin(a)))
        if not moving_only:
            out.append(net)
            if self.world.net.deformed:        # the wall the current pushes in: what the sonar sees
                wall = Marker(ns="net_wall", id=0, type=Marker.LINE_STRIP, action=Marker.ADD)
                wall.scale.x = 0.1
                wall.color.r, wall.color.g, wall.color.b, wall.color.a = 0.1, 0.6, 1.0, 0.8
                poly = self.world.net.polygon
                wall.points = [Point(x=float(x), y=float(y)) for x, y in np.vstack([poly, poly[:1]])]
                out.append(wall)
        for group, known in ((self.world.known, True), (self.world.unknown, False)):
            for i, ob in enumerate(group):
                if moving_only and not ob.moving:
                    continue
                m = Marker(ns="known" if known else "unknown", id=i, action=Marker.ADD,
                           type=Marker.CUBE if ob.shape == "square" else Marker.CYLINDER)
                m.pose.position.x, m.pose.position.y = ob.centre(t)
                m.pose.orientation.w = 1.0
                side = ob.size if ob.shape == "square" else 2 * ob.size
                m.scale.x, m.scale.y, m.scale.z = side, side, 1.0
                m.color.r, m.color.g, m.color.b, m.color.a = (0.4, 0.4, 0.4, 1.0) if known else (0.6, 0.35, 0.2, 1.0)
                out.append(m)
        if self.fish is not None:              # where the schools are now (they flee the vehicle)
            for k, ((x, y), r) in enumerate(zip(self.fish.pos, self.fish.radius)):
                m = Marker(ns="schools", id=k, action=Marker.ADD, type=Marker.CYLINDER)
                m.pose.position.x, m.pose.position.y = float(x), float(y)
                m.pose.orientation.w = 1.0
                m.scale.x = m.scale.y = 2 * float(r)
                m.scale.z = 0.5
                m.color.r, m.color.g, m.color.b, m.color.a = 0.3, 0.8, 0.9, 0.5
                out.append(m)
        for m in out:
            m.header.stamp, m.header.frame_id = time_msg(t_ns), self.p["frame_id"]
        return MarkerArray(markers=out)


def main(args=None) -> None:
    run_node(SimNode, args)


if __name__ == "__main__":
    main()
