"""Single nodes against a probe: failsafes, stale data, bad parameters and files, planner answers."""
from __future__ import annotations

import math

import numpy as np
import pytest
from cage_planner_msgs.msg import HeadingSetpoint, Mission, MissionEvent, PlannerStatus
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry, Path
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import LaserScan

from cage_sim.ros_convert import mission_msg, odom_pose, scan_msg, time_msg, world_to_map, yaw_to_quaternion
from cage_sim.scenarios import builtin_file
from cage_sim.sonar import SonarModel
from cage_sim.vehicle import propagate

from graph_testlib import ROOT

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def odom(x, y, yaw, t_ns) -> Odometry:
    m = Odometry()
    m.header.stamp, m.header.frame_id = time_msg(t_ns), "map"
    m.pose.pose.position.x, m.pose.pose.position.y = x, y
    m.pose.pose.orientation = yaw_to_quaternion(yaw)
    return m


def connected(probe, pub, timeout=15.0) -> bool:
    return probe.until(lambda: pub.get_subscription_count() > 0, timeout)


class PolicyRig:
    """A policy_node (baseline driver) on a straight 20 m plan, fed pose + scan decision by decision."""

    def __init__(self, launch, probe, *params: str, policy: str = "baseline"):
        self.probe = probe
        self.setpoints = probe.listen(HeadingSetpoint, "/cage/heading_setpoint")
        self.events = probe.listen(MissionEvent, "/cage/mission_event")
        mission_pub = probe.node.create_publisher(Mission, "/cage/mission", LATCHED)
        self.odom_pub = probe.node.create_publisher(Odometry, "/cage/odom", 10)
        self.scan_pub = probe.node.create_publisher(LaserScan, "/cage/scan", qos_profile_sensor_data)
        self.node = launch("cage_reactive_ddpg", "policy_node", "-p", f"policy:={policy}", *params)
        assert connected(probe, self.scan_pub), self.node.output
        mission_pub.publish(mission_msg(1, Mission.ACTIVE, (20.0, 0.0), [(20.0, 0.0)], 0))
        assert probe.until(lambda: "following a route" in self.node.output, 10), self.node.output
        self.sonar = SonarModel()

    def decision(self, t_s: int, ranges, x: float | None = None) -> bool:
        """Pose at (x or t_s metres, 0) then a scan, both stamped t_s; True once a setpoint answers."""
        t_ns = int(t_s * 1e9)
        self.odom_pub.publish(odom(float(t_s if x is None else x), 0.0, 0.0, t_ns))
        self.probe.until(lambda: False, 0.15)
        n = len(self.setpoints)
        self.scan_pub.publish(scan_msg(ranges, self.sonar, t_ns))
        return self.probe.until(lambda: len(self.setpoints) > n, 5)


def test_policy_node_failsafe_on_invalid_and_wrong_size_scans(launch, probe):
    rig = PolicyRig(launch, probe)
    setpoints, events, node, decision = rig.setpoints, rig.events, rig.node, rig.decision
    assert decision(0, [float("nan")] * 72), node.output
    sp = setpoints[-1]
    assert sp.source == HeadingSetpoint.SOURCE_FAILSAFE and sp.speed == 0.0
    assert probe.until(lambda: any(e.event == MissionEvent.FAILSAFE for e in events), 5)
    assert "invalid" in events[-1].detail

    assert decision(1, [10.0] * 36)                      # a scan of the wrong size
    assert setpoints[-1].source == HeadingSetpoint.SOURCE_FAILSAFE
    assert probe.until(lambda: "36 ranges" in events[-1].detail, 5)   # (the log line is throttled)

    assert decision(2, [math.inf] * 70 + [float("nan")] * 2)   # a few NaN: read as no return, a real decision
    sp = setpoints[-1]
    assert sp.source == HeadingSetpoint.SOURCE_BASELINE and sp.speed == 1.0 and sp.decision == 2
    assert abs(sp.heading) < 1e-6                        # open water, waypoint dead ahead
    assert "Traceback" not in node.output


def test_policy_node_refuses_mismatched_weights(launch, tmp_path):
    from cage_reactive_ddpg.policy import shipped_path
    import json, shutil
    w = shipped_path()
    bad = tmp_path / "policy.safetensors"
    shutil.copy(w, bad)
    meta = json.loads(w.with_suffix(".json").read_text())
    meta["observation_layout"]["n_beams"] = 36
    bad.with_suffix(".json").write_text(json.dumps(meta))
    node = launch("cage_reactive_ddpg", "policy_node", "-p", f"policy:={bad}")
    assert node.proc.wait(timeout=30) == 2
    assert "n_beams" in node.output and "Traceback" not in node.output


def test_policy_node_with_a_sensor_alone_loads_that_profiles_driver(launch, probe):
    """``sensor:=fls`` and no ``policy``: the fls profile's shipped driver (``policy.DRIVERS``), where
    before session 50 the default study policy was loaded and refused; a bad profile: exit 2, named."""
    from cage_reactive_ddpg.policy import shipped_path
    node = launch("cage_reactive_ddpg", "policy_node", "-p", "sensor:=fls")
    loaded = f"{shipped_path('fls').name} loaded (sensor 'fls'"
    assert probe.until(lambda: loaded in node.output, 30), node.output
    bad = launch("cage_reactive_ddpg", "policy_node", "-p", "sensor:=sidescan")
    assert bad.proc.wait(timeout=30) == 2
    assert "sidescan" in bad.output and "Traceback" not in node.output + bad.output


def test_vehicle_holds_station_when_setpoints_go_stale(launch, probe):
    from rosgraph_msgs.msg import Clock
    odoms = probe.listen(Odometry, "/cage/odom")
    clocks = probe.listen(Clock, "/clock")
    events = probe.listen(MissionEvent, "/cage/mission_event")
    sp_pub = probe.node.create_publisher(HeadingSetpoint, "/cage/heading_setpoint", 10)
    node = launch("cage_sim", "vehicle_node", "-p", "scenario:=study2d", "-p", "seed:=1",
                  "-p", "setpoint_timeout:=0.5", "-p", "time_scale:=10.0")
    assert probe.until(lambda: len(odoms) > 0 and sp_pub.get_subscription_count() > 0, 15), node.output
    sp = HeadingSetpoint(heading=0.3, speed=1.0, decision=0)
    sp.header.stamp = time_msg(0)
    sp_pub.publish(sp)
    assert probe.until(lambda: any(e.event == MissionEvent.FAILSAFE for e in events), 10), node.output
    last = [o for o in odoms if o.header.stamp.sec == 1 and o.header.stamp.nanosec == 0]
    assert last, "the vehicle stops at the next decision boundary"
    x0, y0, yaw0 = odom_pose(odoms[0])
    expected = propagate(x0, y0, yaw0, 0.3, 1.0)          # one decision of the continuous model
    assert odom_pose(last[-1]) == pytest.approx(expected, abs=1e-9)
    n = len(odoms)
    probe.until(lambda: False, 0.5)
    assert all(o.header.stamp.sec <= 1 for o in odoms[n:]), "the clock stands while waiting"
    assert "no setpoint" in events[-1].detail
    # /clock carries the vehicle's sim time: it reached the boundary and stands there
    assert clocks and {(c.clock.sec, c.clock.nanosec) for c in clocks} <= {(o.header.stamp.sec, o.header.stamp.nanosec)
                                                                            for o in odoms}
    assert (clocks[-1].clock.sec, clocks[-1].clock.nanosec) == (1, 0)


def test_rrt_node_plans_and_reports_failures(launch, probe):
    sc = builtin_file("full_cage.yaml")
    paths = probe.listen(Path, "/cage/plan", LATCHED)
    statuses = probe.listen(PlannerStatus, "/cage/planner_status", LATCHED)
    map_pub = probe.node.create_publisher(type(world_to_map(sc.world, 0)), "/cage/map", LATCHED)
    odom_pub = probe.node.create_publisher(Odometry, "/cage/odom", 10)
    goal_pub = probe.node.create_publisher(PoseStamped, "/cage/plan_request", 10)
    node = launch("cage_global_rrt", "rrt_node", "--params-file", str(ROOT / "ros2_ws/src/cage_global_rrt/config/rrt.yaml"))
    map_pub.publish(world_to_map(sc.world, 0))
    assert connected(probe, goal_pub), node.output

    def ask(x, y):
        odom_pub.publish(odom(*sc.start, 0))
        probe.until(lambda: False, 0.3)
        g = PoseStamped()
        g.header.frame_id, g.header.stamp = "map", time_msg(stamp[0])
        stamp[0] += 1
        g.pose.position.x, g.pose.position.y = x, y
        n = len(statuses)
        goal_pub.publish(g)
        assert probe.until(lambda: len(statuses) > n, 10), node.output
        assert statuses[-1].header.stamp == g.header.stamp, "the answer carries the request's stamp"
        return statuses[-1]

    stamp = [1_000]

    st = ask(*sc.goal)
    assert st.code == PlannerStatus.SUCCESS and st.n_waypoints >= 2
    assert probe.until(lambda: len(paths) > 0 and len(paths[-1].poses) == st.n_waypoints, 5)
    last = paths[-1].poses[-1].pose.position
    assert (last.x, last.y) == pytest.approx(sc.goal)

    ob = sc.world.known[0]
    assert ask(ob.x, ob.y).code == PlannerStatus.GOAL_OCCUPIED
    assert ask(45.0, 0.0).code == PlannerStatus.GOAL_OUTSIDE_NET
    assert probe.until(lambda: len(paths[-1].poses) == 0, 5), "a failed request clears the plan"

    assert ask(*sc.goal).code == PlannerStatus.SUCCESS
    event_pub = probe.node.create_publisher(MissionEvent, "/cage/mission_event", 10)
    assert connected(probe, event_pub)
    here = (sc.start[0] + 2.0, sc.start[1] + 1.0, 0.0)            # the vehicle has moved on
    odom_pub.publish(odom(*here, 5_000_000_000))
    probe.until(lambda: False, 0.3)
    n = len(statuses)
    event_pub.publish(MissionEvent(event=MissionEvent.REPLAN_REQUESTED, detail="test"))
    assert probe.until(lambda: len(statuses) > n, 10), node.output
    assert statuses[-1].code == PlannerStatus.SUCCESS
    assert probe.until(lambda: paths[-1].poses and (paths[-1].poses[0].pose.position.x,
                                                    paths[-1].poses[0].pose.position.y) == pytest.approx(here[:2]), 5)


def test_sim_node_rejects_a_bad_scenario_file(launch, tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("start: [0.0, 0.0, 0.0]\ngoal: [50.0, 0.0]\n")
    node = launch("cage_sim", "sim_node", "-p", f"scenario:={bad}")
    assert node.proc.wait(timeout=30) == 2
    assert "goal:" in node.output and "outside the net" in node.output and "Traceback" not in node.output


def test_sim_node_publishes_map_and_scans(launch, probe):
    maps = probe.listen(type(world_to_map(builtin_file("full_cage.yaml").world, 0)), "/cage/map", LATCHED)
    scans = probe.listen(LaserScan, "/cage/scan", qos_profile_sensor_data)
    odom_pub = probe.node.create_publisher(Odometry, "/cage/odom", 10)
    node = launch("cage_sim", "sim_node")
    assert probe.until(lambda: len(maps) == 1, 15), node.output
    assert maps[0].net_radius == 30.0 and len(maps[0].obstacles) == 20
    assert connected(probe, odom_pub)
    odom_pub.publish(odom(0.0, 0.0, 0.0, 0))
    assert probe.until(lambda: len(scans) > 0, 5)
    s = scans[0]
    assert len(s.ranges) == 72 and s.range_max == 20.0 and s.header.frame_id == "base_link"


def test_policy_node_asks_for_a_replan_without_progress(launch, probe):
    rig = PolicyRig(launch, probe, "-p", "replan_after:=3")
    for k in range(6):   # the vehicle reports the same place at every decision: no progress
        assert rig.decision(k, [10.0] * 72, x=0.0), rig.node.output
    replans = lambda: [e for e in rig.events if e.event == MissionEvent.REPLAN_REQUESTED]  # noqa: E731
    assert probe.until(lambda: len(replans()) > 0, 5), rig.node.output
    assert "no progress" in replans()[0].detail and replans()[0].mission_id == 1
    assert all(sp.mission_id == 1 for sp in rig.setpoints)


def shield_case():
    """A scan where the shield overrides the shipped policy, found with the real policy, shield and
    Driver as the node has them (the policy's own layout and memory, no DVL reading): the vehicle at
    the origin heading +x, the goal 20 m ahead, a wall of returns ahead. Returns (ranges, shielded
    action, raw action), the raw one as the node decides it at the next decision from the same place."""
    from cage_reactive_ddpg.policy import env_config_for, load_policy
    from cage_sim.controller import ArcController
    from cage_sim.driver import Driver
    from cage_sim.route import RouteTracker
    from cage_sim.shield import SafetyShield
    pol = load_policy()
    cfg = env_config_for(pol.metadata)

    def decide(policy, ranges, times):
        drv = Driver(policy, cfg.layout, cfg.vehicle)
        tracker = RouteTracker((0.0, 0.0), np.array([[20.0, 0.0]]), cfg.waypoint_radius)
        tracker.advance(0.0, 0.0)
        return [drv.decide(np.array(ranges), (0.0, 0.0, 0.0), t, None, tracker) for t in times][-1]

    for dist in (1.6, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0):
        for half in (2, 4, 6, 9):
            ranges = [math.inf] * 72
            for k in range(-half, half + 1):
                ranges[k % 72] = dist / math.cos(math.radians(5.0 * k))
            shielded, overridden = decide(SafetyShield(pol, ArcController(cfg.layout, cfg.vehicle)), ranges, [0.0])
            if overridden:
                return ranges, shielded, decide(pol, ranges, [0.0, 1.0])[0]
    raise AssertionError("no scan found where the shield overrides the policy")


def test_param_set_shield_false_changes_the_policy_node(launch, probe):
    """What `ros2 param set /cage/policy_node shield false` sends: SetParameters on the node's service."""
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters
    ranges, shielded, raw = shield_case()
    rig = PolicyRig(launch, probe, policy="")                       # the shipped policy, shield on
    assert rig.decision(0, ranges, x=0.0), rig.node.output
    sp = rig.setpoints[-1]
    assert sp.source == HeadingSetpoint.SOURCE_SHIELD and sp.heading == pytest.approx(shielded * math.radians(20))

    client = probe.node.create_client(SetParameters, "/cage/policy_node/set_parameters")
    assert probe.until(client.service_is_ready, 15)

    def set_param(name, value):
        typ = ParameterType.PARAMETER_BOOL if isinstance(value, bool) else ParameterType.PARAMETER_DOUBLE
        val = ParameterValue(type=typ, bool_value=value) if typ == ParameterType.PARAMETER_BOOL else \
            ParameterValue(type=typ, double_value=value)
        fut = client.call_async(SetParameters.Request(parameters=[Parameter(name=name, value=val)]))
        assert probe.until(fut.done, 10)
        return fut.result().results[0]

    refused = set_param("speed", 2.0)                               # read at start only: refused, with why
    assert not refused.successful and "restart" in refused.reason
    wrong = set_param("stall_recovery", 1.5)                        # settable, but a bool
    assert not wrong.successful and "bool" in wrong.reason.lower()
    assert set_param("stall_recovery", False).successful
    assert probe.until(lambda: "stall recovery off" in rig.node.output, 5), rig.node.output
    assert set_param("goal_search", False).successful
    assert probe.until(lambda: "goal search off" in rig.node.output, 5), rig.node.output
    assert set_param("shield", False).successful
    assert rig.decision(1, ranges, x=0.0), rig.node.output           # the same place and scan again
    sp = rig.setpoints[-1]
    assert sp.source == HeadingSetpoint.SOURCE_POLICY and sp.heading == pytest.approx(raw * math.radians(20))
    assert "safety shield off" in rig.node.output


def test_policy_node_keeps_its_shield_clear_of_the_known_map(launch, probe):
    """The shield keeps clear of the ``map`` topic's obstacles beside the sonar's returns: with an
    empty scan (open water) and a known square on the route 4 m ahead, the node turns away as the
    offline Driver with the same map does; ``ros2 param set ... known_map false`` puts it back on the
    returns alone (straight at the waypoint); a bad map is refused by name and the node flies on."""
    from cage_planner_msgs.msg import CageMap
    from cage_reactive_ddpg.policy import env_config_for, load_policy
    from cage_sim.controller import ArcController
    from cage_sim.driver import Driver
    from cage_sim.map_points import MapPoints
    from cage_sim.route import RouteTracker
    from cage_sim.shield import SafetyShield
    from cage_sim.world import Obstacle, World
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters
    world = World(30.0, (Obstacle("square", 4.0, 0.0, 2.0),))
    ranges = [math.inf] * 72
    pol = load_policy()
    cfg = env_config_for(pol.metadata)
    drv = Driver(SafetyShield(pol, ArcController(cfg.layout, cfg.vehicle)), cfg.layout, cfg.vehicle,
                 known=MapPoints.from_world(world))
    tracker = RouteTracker((0.0, 0.0), np.array([[20.0, 0.0]]), cfg.waypoint_radius)
    tracker.advance(0.0, 0.0)
    with_map = drv.decide(np.array(ranges), (0.0, 0.0, 0.0), 0.0, None, tracker)[0]
    drv.known = None
    without = drv.decide(np.array(ranges), (0.0, 0.0, 0.0), 1.0, None, tracker)[0]
    assert abs(with_map) > 0.5 and without == pytest.approx(0.0, abs=1e-6)

    rig = PolicyRig(launch, probe, policy="")                       # the shipped policy, shield on
    map_pub = probe.node.create_publisher(CageMap, "/cage/map", LATCHED)
    map_pub.publish(world_to_map(world, 0))
    assert probe.until(lambda: "known map: net radius 30 m, 1 obstacles" in rig.node.output, 10), rig.node.output
    assert rig.decision(0, ranges, x=0.0), rig.node.output
    assert rig.setpoints[-1].heading == pytest.approx(with_map * math.radians(20))

    client = probe.node.create_client(SetParameters, "/cage/policy_node/set_parameters")
    assert probe.until(client.service_is_ready, 15)
    off = Parameter(name="known_map", value=ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=False))
    fut = client.call_async(SetParameters.Request(parameters=[off]))
    assert probe.until(fut.done, 10) and fut.result().results[0].successful
    assert rig.decision(1, ranges, x=0.0), rig.node.output
    assert rig.setpoints[-1].heading == pytest.approx(without * math.radians(20), abs=1e-6)

    bad = world_to_map(world, 0)
    bad.net_radius = -1.0
    map_pub.publish(bad)
    assert probe.until(lambda: "map refused" in rig.node.output, 10), rig.node.output
    assert "net_radius" in rig.node.output
    elsewhere = world_to_map(world, 0, frame="odom")
    map_pub.publish(elsewhere)
    assert probe.until(lambda: "frame 'odom', not the odometry's 'map'" in rig.node.output, 10), rig.node.output
    assert rig.decision(2, ranges, x=0.0), rig.node.output
