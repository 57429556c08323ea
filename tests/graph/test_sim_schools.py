"""sim_node and the fish schools: RViz sees them (and the wall the current pushes in), and they stay where
they are from one mission to the next (goal after goal in the same water), in-process like
tests/faults/test_sim_markers.py."""
from __future__ import annotations

import numpy as np
from cage_planner_msgs.msg import Mission as MissionMsg
from nav_msgs.msg import Odometry

from cage_sim.ros_convert import mission_msg, time_msg, yaw_to_quaternion


def _odom(node, t_ns: int, pose) -> None:
    m = Odometry()
    m.header.stamp = time_msg(t_ns)
    m.pose.pose.position.x, m.pose.pose.position.y = float(pose[0]), float(pose[1])
    m.pose.pose.orientation = yaw_to_quaternion(float(pose[2]))
    node.on_odom(m)


def test_schools_are_drawn_and_carried_on_from_mission_to_mission():
    import rclpy
    rclpy.init(args=["--ros-args", "-p", "scenario:=cage?current=0.5&schools=3", "-p", "seed:=4"])
    try:
        from cage_sim.nodes.sim_node import SimNode
        node = SimNode()
        full = [m.ns for m in node.markers(0).markers]
        assert full.count("schools") == 3 and full.count("net_wall") == 1     # 0.5 m/s deforms the net
        assert [m.ns for m in node.markers(0, moving_only=True).markers] == ["schools"] * 3
        home = node.fish.pos.copy()
        start, goal, period = node.scenario.start, node.scenario.goal, node.period_ns
        node.on_mission(mission_msg(1, MissionMsg.ACTIVE, goal, [goal], 0))
        for k in range(25):                                   # holding station: the schools wander
            _odom(node, k * period, start)
        first = node.mission
        assert first.fish is node.fish and first.steps > 10
        moved = node.fish.pos.copy()
        assert not np.allclose(moved, home)
        node.on_mission(mission_msg(2, MissionMsg.ACTIVE, goal, [goal], 24 * period))
        assert node.mission is not first and node.mission_id == 2      # from the last decision's pose
        assert node.mission.fish is node.fish and np.array_equal(node.fish.pos, moved)   # not back home
        _odom(node, 25 * period, start)
        assert node.mission.steps == 1 and not np.array_equal(node.fish.pos, moved)     # and on they go
        moved = node.fish.pos.copy()
        drawn = np.array([(m.pose.position.x, m.pose.position.y) for m in node.markers(0, moving_only=True).markers])
        assert np.allclose(drawn, moved)
        node.destroy_node()
    finally:
        rclpy.try_shutdown()
