"""Item 3: many obstacles with one moving must not make the simulator rebuild every marker per
odometry message (10,000 obstacles took ~4 s per MarkerArray: the graph livelocked)."""
from __future__ import annotations

import math
import time

import yaml
from nav_msgs.msg import Odometry

from cage_sim.ros_convert import time_msg, yaw_to_quaternion


def test_markers_go_out_once_in_full_then_only_the_moving_ones_at_a_bounded_rate(tmp_path):
    import rclpy
    obs = [{"shape": "circle", "x": -25.0 + i * 1.25, "y": -25.0 + j * 1.25, "size": 0.02}
           for i in range(41) for j in range(41)
           if math.hypot(-25.0 + i * 1.25, -25.0 + j * 1.25) < 27 and abs(-25.0 + j * 1.25) > 3]
    obs[0].update(ax=1.0, ay=0.0, period=20.0)                      # one moving school among ~1,000
    f = tmp_path / "many.yaml"
    f.write_text(yaml.safe_dump({"name": "many", "start": [-20.0, 0.0, 0.0], "goal": [20.0, 0.0],
                                 "unknown_obstacles": obs}))
    rclpy.init(args=["--ros-args", "-p", f"scenario:={f}", "-p", "marker_rate:=2.0"])
    try:
        from cage_sim.nodes.sim_node import SimNode
        node = SimNode()
        sent = []
        publish = node.marker_pub.publish
        node.marker_pub.publish = lambda msg: (sent.append(len(msg.markers)), publish(msg))
        t0 = time.monotonic()
        for k in range(60):
            m = Odometry()
            m.header.stamp = time_msg(k * 100_000_000)
            m.pose.pose.position.x = -20.0 + 0.1 * k
            m.pose.pose.orientation = yaw_to_quaternion(0.0)
            node.on_odom(m)
        elapsed = time.monotonic() - t0
        assert 1 <= len(sent) <= math.ceil(elapsed * 2.0) + 1      # at most marker_rate per wall second
        assert set(sent) == {1}                                   # only the moving one, never all ~1,000
        node.destroy_node()
    finally:
        rclpy.try_shutdown()
