"""Message conversions at the nodes' edge (needs only the message packages, no middleware)."""
import math

import numpy as np
import pytest

from cage_sim.ros_convert import (map_to_world, path_msg, path_points, quaternion_to_yaw, scan_msg, stamp_ns,
                                  time_msg, world_to_map, yaw_to_quaternion)
from cage_sim.scenarios import builtin_file
from cage_sim.sonar import SonarModel
from cage_sim.world import Obstacle


@pytest.mark.parametrize("yaw", [0.0, 1.0, -2.5, math.pi - 1e-9])
def test_yaw_quaternion_round_trip(yaw):
    assert quaternion_to_yaw(yaw_to_quaternion(yaw)) == pytest.approx(yaw)


def test_time_is_exact_nanoseconds():
    ns = 123 * 1_000_000_000 + 456
    assert stamp_ns(time_msg(ns)) == ns


def test_known_map_round_trip_keeps_only_known_obstacles():
    w = builtin_file("full_cage.yaml").world
    back = map_to_world(world_to_map(w, 0))
    assert back.net_radius == w.net_radius and back.known == w.known and back.unknown == ()


def test_map_with_unknown_shape_or_nan_is_refused():
    msg = world_to_map(builtin_file("full_cage.yaml").world, 0)
    msg.obstacles[0].shape = 7
    with pytest.raises(ValueError, match=r"obstacles\[0\].shape"):
        map_to_world(msg)
    msg.obstacles[0].shape = 0
    msg.obstacles[1].x = float("nan")
    with pytest.raises(ValueError, match="finite"):
        map_to_world(msg)
    with pytest.raises(ValueError, match="finite"):
        Obstacle("circle", 0.0, float("inf"), 1.0)


def test_scan_message_follows_laserscan_conventions():
    s = SonarModel()
    ranges = np.r_[np.full(70, 5.0), np.inf, 3.0]
    msg = scan_msg(ranges, s, 2_500_000_000)
    assert msg.header.frame_id == "base_link" and msg.header.stamp.sec == 2 and msg.header.stamp.nanosec == 5e8
    assert msg.angle_min == 0.0 and msg.angle_increment == pytest.approx(math.radians(5))
    assert msg.angle_max == pytest.approx(math.radians(355)) and msg.range_max == 20.0
    assert len(msg.ranges) == 72 and math.isinf(msg.ranges[70])


def test_path_round_trip():
    pts = [(0.0, 0.0), (3.0, 4.0), (6.0, 8.0)]
    assert path_points(path_msg(pts, 0)) == pytest.approx(np.array(pts))
