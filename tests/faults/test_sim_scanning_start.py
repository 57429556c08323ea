"""A mission that reaches sim_node after the vehicle's first odometry (a wall-time race of the DDS
graph) must start its scanning head where offline does: at the start pose and time. Before, the new
head stayed unprimed until the next decision and filled its whole first sweep there, so the graph
flew another mission than offline (cage seed 1 with the baseline: goal after 33 decisions instead of
offline's collision after 30, in 2 of many loaded full-suite runs)."""
from __future__ import annotations

import math

import numpy as np
from nav_msgs.msg import Odometry

from cage_sim.ros_convert import mission_msg, time_msg, yaw_to_quaternion


def odom(t_ns: int, pose) -> Odometry:
    m = Odometry()
    m.header.stamp = time_msg(t_ns)
    m.pose.pose.position.x, m.pose.pose.position.y = float(pose[0]), float(pose[1])
    m.pose.pose.orientation = yaw_to_quaternion(pose[2])
    return m


def test_mission_after_the_first_odometry_primes_the_scanning_head_at_the_start():
    import rclpy
    from cage_planner_msgs.msg import Mission as MissionMsg
    rclpy.init(args=["--ros-args", "-p", "scenario:=cage", "-p", "seed:=1", "-p", "sensor:=scanning",
                     "-p", "noise_std:=0.0", "-p", "dropout:=0.0"])
    try:
        from cage_sim.nodes.sim_node import SimNode
        node = SimNode()
        start = node.scenario.start
        x, y, yaw = start
        moved = (x + math.cos(yaw), y + math.sin(yaw), yaw)              # one decision straight on
        node.on_odom(odom(0, start))                                     # the vehicle is there first
        node.on_mission(mission_msg(1, MissionMsg.ACTIVE, node.scenario.goal, [node.scenario.goal], 0))
        assert node.mission is not None and node.head.last is not None   # started and primed at t = 0
        node.on_odom(odom(node.period_ns, moved))
        ref = node.sonar.head()                                          # offline: reset at the start,
        ref.reset(node.world, *start, 0.0)                               # stepped to the next decision
        want = ref.update(node.world, *moved, node.period_ns / 1e9)
        got = node.head.last
        assert np.array_equal(got.stamps, want.stamps)
        assert np.allclose(got.ranges, want.ranges, equal_nan=True) and np.allclose(got.origins, want.origins)
        node.destroy_node()
    finally:
        rclpy.try_shutdown()
