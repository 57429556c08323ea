"""Item 2: a node restarted mid-mission picks the mission up where it is: the vehicle keeps the sim
clock and pose (from the simulator's latched track), the policy and the simulator follow the rest of
the latched route from the current pose, never a leg back to the mission start."""
from __future__ import annotations

import math
import re

import pytest
from cage_planner_msgs.msg import HeadingSetpoint, Mission, MissionEvent
from nav_msgs.msg import Odometry, Path
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import LaserScan

from cage_sim.ros_convert import mission_msg, odom_pose, stamp_ns

from faultlib import LATCHED, assert_clean, odom, scan, track

S = 1_000_000_000
# a route that turns back on itself: from (10, 2) the way on is north, the mission start is south-west
ROUTE = [(10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]


def test_restarted_vehicle_resumes_from_the_latched_track(launch, probe):
    odoms = probe.listen(Odometry, "/cage/odom")
    track_pub = probe.node.create_publisher(Path, "/cage/track", LATCHED)
    track_pub.publish(track([(-5.0, -5.0, 0.0), (-4.0, -5.0, 0.0), (2.0, 3.0, 1.0)], 37 * S))
    node = launch("cage_sim", "vehicle_node", "-p", "scenario:=study2d", "-p", "seed:=1", "-p", "resume_wait:=10.0")
    assert probe.until(lambda: odoms, 30), node.output
    assert stamp_ns(odoms[0].header.stamp) == 37 * S             # its first pose: where the mission is
    assert odom_pose(odoms[0]) == pytest.approx((2.0, 3.0, 1.0))
    assert "resumed the mission under way at t=37.0 s" in node.output
    assert_clean(node.output)


def test_restarted_policy_follows_the_rest_of_the_route(launch, probe):
    setpoints = probe.listen(HeadingSetpoint, "/cage/heading_setpoint")
    mission_pub = probe.node.create_publisher(Mission, "/cage/mission", LATCHED)
    odom_pub = probe.node.create_publisher(Odometry, "/cage/odom", 10)
    scan_pub = probe.node.create_publisher(LaserScan, "/cage/scan", qos_profile_sensor_data)
    mission_pub.publish(mission_msg(1, Mission.ACTIVE, ROUTE[-1], ROUTE, 0))   # latched before it starts
    node = launch("cage_reactive_ddpg", "policy_node", "-p", "policy:=baseline")
    assert probe.until(lambda: "following a route" in node.output and scan_pub.get_subscription_count() > 0,
                       20), node.output
    odom_pub.publish(odom(10.0, 2.0, math.pi / 2, 12 * S))      # mid-mission: heading north on leg 2
    probe.until(lambda: False, 0.2)
    scan_pub.publish(scan(12 * S, [math.inf] * 72))
    assert probe.until(lambda: setpoints, 5), node.output
    sp = setpoints[-1]
    assert sp.source == HeadingSetpoint.SOURCE_BASELINE and sp.decision == 12
    assert abs(sp.heading - math.pi / 2) < math.radians(1)    # on to (10, 10), not back to (10, 0)
    assert "joined under way at t=12.0 s, 2 of 3 waypoints ahead" in node.output
    assert_clean(node.output)


def test_restarted_simulator_judges_the_rest_of_the_route(launch, probe):
    events = probe.listen(MissionEvent, "/cage/mission_event")
    mission_pub = probe.node.create_publisher(Mission, "/cage/mission", LATCHED)
    odom_pub = probe.node.create_publisher(Odometry, "/cage/odom", 10)
    mission_pub.publish(mission_msg(1, Mission.ACTIVE, ROUTE[-1], ROUTE, 0))
    node = launch("cage_sim", "sim_node", "-p", "scenario:=study2d", "-p", "seed:=1")
    assert probe.until(lambda: odom_pub.get_subscription_count() > 0, 20), node.output
    probe.until(lambda: False, 0.5)
    odom_pub.publish(odom(10.0, 2.0, math.pi / 2, 12 * S))
    assert probe.until(lambda: any(e.event == MissionEvent.STARTED for e in events), 10), node.output
    length = float(re.search(r"route ([0-9.]+) m", next(e.detail for e in events
                                                         if e.event == MissionEvent.STARTED)).group(1))
    assert length == pytest.approx(8.0 + 10.0, abs=0.05)      # (10,2)->(10,10)->(0,10), no detour
    for k in range(13, 16):                                   # judged on from there: no wander
        odom_pub.publish(odom(10.0, 2.0 + (k - 12), math.pi / 2, k * S))
        probe.until(lambda: False, 0.15)
    probe.until(lambda: False, 0.5)
    assert not [e for e in events if e.event in (MissionEvent.WANDER, MissionEvent.COLLISION, MissionEvent.TIMEOUT)]
    assert "expected" not in node.output                      # decisions numbered on from 12
    assert_clean(node.output)
