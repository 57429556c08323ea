"""Hostile-input helpers for the fault suite: message builders, process memory, log checks."""
from __future__ import annotations

import math
from pathlib import Path

from cage_planner_msgs.msg import HeadingSetpoint
from nav_msgs.msg import Odometry
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import LaserScan

from cage_sim.ros_convert import path_msg, time_msg, yaw_to_quaternion

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
N = 72
INC = 2 * math.pi / N


def odom(x: float, y: float, yaw: float, t_ns: int) -> Odometry:
    m = Odometry()
    m.header.stamp, m.header.frame_id = time_msg(t_ns), "map"
    m.pose.pose.position.x, m.pose.pose.position.y = x, y
    m.pose.pose.orientation = yaw_to_quaternion(yaw)
    return m


def scan(t_ns: int, ranges, frame: str = "base_link", angle_min: float = 0.0, inc: float = INC) -> LaserScan:
    """A LaserScan with every field settable (the sim's scan_msg would not let us lie)."""
    m = LaserScan()
    m.header.stamp, m.header.frame_id = time_msg(t_ns), frame
    m.angle_min, m.angle_increment = float(angle_min), float(inc)
    m.angle_max = float(angle_min + inc * (max(len(ranges), 1) - 1))
    m.range_min, m.range_max = 0.0, 20.0
    m.ranges = [float(r) for r in ranges]
    return m


def setpoint(t_ns: int, heading: float, speed: float = 1.0, mission_id: int = 1) -> HeadingSetpoint:
    sp = HeadingSetpoint(heading=float(heading), speed=float(speed), decision=int(t_ns // 1_000_000_000),
                         source=HeadingSetpoint.SOURCE_BASELINE, mission_id=mission_id)
    sp.header.stamp, sp.header.frame_id = time_msg(t_ns), "map"
    return sp


def track(poses, t_ns: int):
    """The simulator's latched track: judged poses (x, y, yaw), stamped with the last decision."""
    return path_msg(poses, t_ns)


def rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return math.nan


def cpu_s(pid: int) -> float:
    """User + system CPU seconds of a process (its children are execs, so one pid)."""
    f = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    import os
    return (int(f[11]) + int(f[12])) / os.sysconf("SC_CLK_TCK")


def assert_clean(output: str) -> None:
    assert "Traceback" not in output, output[-3000:]
