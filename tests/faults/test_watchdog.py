"""Item 1: the vehicle's own watchdog holds station within 1 s of *sim* time when setpoints stop,
in both modes and at a high time scale; the policy's scan watchdog runs in sim time too."""
from __future__ import annotations

import math

import pytest
from cage_planner_msgs.msg import HeadingSetpoint, Mission, MissionEvent
from nav_msgs.msg import Odometry
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import LaserScan

from cage_sim.ros_convert import mission_msg, odom_pose, stamp_ns

from faultlib import LATCHED, assert_clean, odom, scan, setpoint

S = 1_000_000_000


def start_vehicle(launch, probe, *params):
    odoms = probe.listen(Odometry, "/cage/odom")
    events = probe.listen(MissionEvent, "/cage/mission_event")
    mission_pub = probe.node.create_publisher(Mission, "/cage/mission", LATCHED)
    sp_pub = probe.node.create_publisher(HeadingSetpoint, "/cage/heading_setpoint", 10)
    node = launch("cage_sim", "vehicle_node", "-p", "scenario:=study2d", "-p", "seed:=1", "-p", "resume:=false",
                  *params)
    assert probe.until(lambda: sp_pub.get_subscription_count() > 0 and odoms, 20), node.output
    mission_pub.publish(mission_msg(1, Mission.ACTIVE, (0.0, 0.0), [(0.0, 0.0)], 0))
    assert probe.until(lambda: "mission 1" in node.output, 10), node.output
    return node, odoms, events, sp_pub


@pytest.mark.parametrize("lockstep", [False, True])
def test_vehicle_holds_within_one_sim_second_when_setpoints_stop(launch, probe, lockstep):
    node, odoms, events, sp_pub = start_vehicle(
        launch, probe, "-p", f"lockstep:={str(lockstep).lower()}", "-p", "time_scale:=50.0",
        "-p", "setpoint_timeout:=0.5", "-p", "liveness_timeout:=0.5")
    x0, y0, yaw0 = odom_pose(odoms[0])
    sp_pub.publish(setpoint(0, yaw0))                 # one decision, then the policy "dies"
    vehicle_events = lambda: [e for e in events if e.event == MissionEvent.FAILSAFE and "vehicle" in e.detail]
    assert probe.until(lambda: vehicle_events(), 20), node.output
    probe.until(lambda: False, 1.0)                   # (the pose is republished while it holds)
    poses = [(stamp_ns(o.header.stamp), odom_pose(o)) for o in odoms]
    last_t, (xe, ye, _) = poses[-1]
    moved_until = max(t for t, (x, y, _) in poses if math.hypot(x - xe, y - ye) > 1e-9) if any(
        math.hypot(x - xe, y - ye) > 1e-9 for _, (x, y, _) in poses) else 0
    travelled = math.hypot(xe - x0, ye - y0)
    if lockstep:       # the clock stands at the next boundary: exactly one decision flown
        assert last_t == S and travelled == pytest.approx(1.0, abs=0.05)
    else:              # held at most setpoint_timeout after the next decision was due (+ one substep)
        assert moved_until <= int(1.6 * S) and 1.0 < travelled <= 1.61
        assert last_t <= int(1.6 * S)                 # and the clock stands there, as in lockstep
    assert odoms[-1].twist.twist.linear.x == 0.0      # holding: no velocity over ground
    assert any(o.twist.twist.linear.x > 0.9 for o in odoms)   # flying: ~1 m/s forward (DVL-like, body frame)
    assert len(vehicle_events()) == 1                 # said once
    assert node.output.count("holding station") == 1

    n = len(odoms)                                    # setpoints come back: it flies again
    sp_pub.publish(setpoint(stamp_ns(odoms[-1].header.stamp), yaw0))
    assert probe.until(lambda: "resuming" in node.output, 10), node.output
    assert probe.until(lambda: len(odoms) > n + 3, 10)
    xr, yr, _ = odom_pose(odoms[-1])
    assert math.hypot(xr - xe, yr - ye) > 0.05
    assert_clean(node.output)


def test_policy_scan_watchdog_runs_in_sim_time(launch, probe):
    setpoints = probe.listen(HeadingSetpoint, "/cage/heading_setpoint")
    events = probe.listen(MissionEvent, "/cage/mission_event")
    mission_pub = probe.node.create_publisher(Mission, "/cage/mission", LATCHED)
    odom_pub = probe.node.create_publisher(Odometry, "/cage/odom", 10)
    scan_pub = probe.node.create_publisher(LaserScan, "/cage/scan", qos_profile_sensor_data)
    node = launch("cage_reactive_ddpg", "policy_node", "-p", "policy:=baseline", "-p", "lockstep:=false",
                  "-p", "scan_timeout:=1.0", "-p", "liveness_timeout:=60.0")
    assert probe.until(lambda: scan_pub.get_subscription_count() > 0, 20), node.output
    mission_pub.publish(mission_msg(1, Mission.ACTIVE, (20.0, 0.0), [(20.0, 0.0)], 0))
    assert probe.until(lambda: "following a route" in node.output, 10), node.output
    odom_pub.publish(odom(0.0, 0.0, 0.0, 0))
    probe.until(lambda: False, 0.2)
    scan_pub.publish(scan(0, [math.inf] * 72))
    assert probe.until(lambda: setpoints, 5), node.output
    assert setpoints[-1].source == HeadingSetpoint.SOURCE_BASELINE
    # the simulator goes quiet while the clock runs on: 0.9 s of sim time is fine, 1.2 s is not
    odom_pub.publish(odom(0.9, 0.0, 0.0, int(0.9 * S)))
    probe.until(lambda: False, 0.5)          # (a wall-clock watchdog would not care either way)
    assert not [e for e in events if e.event == MissionEvent.FAILSAFE]
    odom_pub.publish(odom(1.2, 0.0, 0.0, int(1.2 * S)))
    assert probe.until(lambda: any(e.event == MissionEvent.FAILSAFE for e in events), 5), node.output
    assert "of sim time" in events[-1].detail
    assert setpoints[-1].source == HeadingSetpoint.SOURCE_FAILSAFE and setpoints[-1].speed == 0.0
    assert_clean(node.output)


def test_simulator_notices_a_silent_vehicle_once(launch, probe):
    odom_pub = probe.node.create_publisher(Odometry, "/cage/odom", 10)
    node = launch("cage_sim", "sim_node", "-p", "scenario:=study2d", "-p", "seed:=1", "-p", "liveness_timeout:=0.5")
    assert probe.until(lambda: odom_pub.get_subscription_count() > 0, 40), node.output
    probe.until(lambda: False, 0.5)
    odom_pub.publish(odom(0.0, 0.0, 0.0, 0))
    assert probe.until(lambda: "the vehicle node is silent" in node.output, 20), node.output
    probe.until(lambda: False, 1.5)
    assert node.output.count("the vehicle node is silent") == 1
    odom_pub.publish(odom(0.0, 0.0, 0.0, S))
    assert probe.until(lambda: "odometry is back" in node.output, 10), node.output
    assert_clean(node.output)
