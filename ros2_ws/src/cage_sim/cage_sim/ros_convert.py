"""Conversions between the ROS messages and the core's plain values, at the edge of the nodes.

Node-side only (imports message packages, not rclpy). Time is carried as integer nanoseconds so
decision boundaries compare exactly.
"""
from __future__ import annotations

import math
from typing import Iterable, Sequence

import numpy as np
from builtin_interfaces.msg import Time
from cage_planner_msgs.msg import CageMap, Mission, MissionEvent, Obstacle as ObstacleMsg
from geometry_msgs.msg import Point, PoseStamped, Quaternion
from nav_msgs.msg import Path
from sensor_msgs.msg import LaserScan

from .sonar import SonarModel
from .world import Obstacle, World

SHAPE_CODES = {"square": ObstacleMsg.SHAPE_SQUARE, "circle": ObstacleMsg.SHAPE_CIRCLE}
SHAPE_NAMES = {v: k for k, v in SHAPE_CODES.items()}
OUTCOME_EVENTS = {"goal": MissionEvent.GOAL_REACHED, "collision": MissionEvent.COLLISION,
                  "wander": MissionEvent.WANDER, "timeout": MissionEvent.TIMEOUT}
EVENT_OUTCOMES = {v: k for k, v in OUTCOME_EVENTS.items()}


def time_msg(ns: int) -> Time:
    return Time(sec=int(ns // 1_000_000_000), nanosec=int(ns % 1_000_000_000))


def stamp_ns(stamp) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def yaw_to_quaternion(yaw: float) -> Quaternion:
    return Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2.0), w=math.cos(yaw / 2.0))


def quaternion_to_yaw(q) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def world_to_map(world: World, ns: int, frame: str = "map") -> CageMap:
    msg = CageMap()
    msg.header.stamp, msg.header.frame_id = time_msg(ns), frame
    msg.net_radius = float(world.net_radius)
    msg.obstacles = [ObstacleMsg(shape=SHAPE_CODES[o.shape], x=float(o.x), y=float(o.y), size=float(o.size))
                     for o in world.known]
    return msg


def map_to_world(msg, safety_radius: float = 0.5) -> World:
    """The known map as a World (raises ValueError on an unknown shape or a bad size)."""
    obs = []
    for i, o in enumerate(msg.obstacles):
        if o.shape not in SHAPE_NAMES:
            raise ValueError(f"obstacles[{i}].shape: unknown code {o.shape}")
        obs.append(Obstacle(SHAPE_NAMES[o.shape], float(o.x), float(o.y), float(o.size)))
    return World(float(msg.net_radius), tuple(obs), (), (0.0, 0.0), safety_radius)


def scan_msg(ranges: np.ndarray, sonar: SonarModel, ns: int, frame: str = "base_link") -> LaserScan:
    """A LaserScan of plain ranges taken all at once at ``ns`` (an electronic sonar; no timing)."""
    return laserscan_msg({"angle_min": sonar.angle_min, "angle_max": sonar.angle_max,
                          "angle_increment": sonar.angle_increment, "time_increment": 0.0, "scan_time": 0.0,
                          "range_min": sonar.min_range, "range_max": sonar.max_range, "ranges": ranges},
                         frame, ns)


def laserscan_msg(fields: dict, frame: str = "base_link", ns: int | None = None) -> LaserScan:
    """A LaserScan from ``sonar.laserscan_fields`` (the profile's sector, timing, beam order); the
    stamp is ``ns`` when given, else the fields' ``stamp`` (seconds)."""
    msg = LaserScan()
    msg.header.stamp = time_msg(ns if ns is not None else int(round(fields["stamp"] * 1e9)))
    msg.header.frame_id = frame
    for k in ("angle_min", "angle_max", "angle_increment", "time_increment", "scan_time", "range_min", "range_max"):
        setattr(msg, k, float(fields[k]))
    msg.ranges = [float(r) for r in fields["ranges"]]
    return msg


def path_msg(points: Iterable[Sequence[float]], ns: int, frame: str = "map") -> Path:
    msg = Path()
    msg.header.stamp, msg.header.frame_id = time_msg(ns), frame
    poses = []
    for p in points:
        ps = PoseStamped()
        ps.header = msg.header
        ps.pose.position.x, ps.pose.position.y = float(p[0]), float(p[1])
        ps.pose.orientation = yaw_to_quaternion(float(p[2]) if len(p) > 2 else 0.0)
        poses.append(ps)
    msg.poses = poses
    return msg


def path_points(msg) -> np.ndarray:
    return np.array([(p.pose.position.x, p.pose.position.y) for p in msg.poses], dtype=float).reshape(-1, 2)


def odom_pose(msg) -> tuple[float, float, float]:
    p = msg.pose.pose
    return float(p.position.x), float(p.position.y), quaternion_to_yaw(p.orientation)


def mission_msg(mission_id: int, state: int, goal: Sequence[float], waypoints: Iterable[Sequence[float]],
                ns: int, frame: str = "map") -> Mission:
    msg = Mission(id=int(mission_id), state=int(state), goal=Point(x=float(goal[0]), y=float(goal[1])),
                  waypoints=[Point(x=float(p[0]), y=float(p[1])) for p in waypoints])
    msg.header.stamp, msg.header.frame_id = time_msg(ns), frame
    return msg


def mission_points(msg) -> np.ndarray:
    """The route of a Mission message as an (n, 2) array (goal last)."""
    return np.array([(p.x, p.y) for p in msg.waypoints], dtype=float).reshape(-1, 2)
