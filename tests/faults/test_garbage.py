"""Item 3: garbage in. Bad parameters and policy files stop a node at start with one line (exit 2);
bad messages on every subscribed topic get a logged, rate-limited refusal or a safe fallback, never a
traceback or a wrong output; a 1 kHz flood costs bounded memory and is not echoed at 1 kHz."""
from __future__ import annotations

import json
import math
import shutil
import time

import pytest
from cage_planner_msgs.msg import HeadingSetpoint, Mission, MissionEvent
from nav_msgs.msg import Odometry
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import LaserScan

from cage_sim.ros_convert import mission_msg, odom_pose, stamp_ns

from faultlib import INC, LATCHED, assert_clean, odom, rss_mb, scan, setpoint

S = 1_000_000_000

BAD_PARAMETERS = [
    ("cage_sim", "vehicle_node", "idle_publish_rate:=0.0"),
    ("cage_sim", "vehicle_node", "time_scale:=0.000001"),
    ("cage_sim", "vehicle_node", "setpoint_timeout:=-1.0"),
    ("cage_sim", "sim_node", "n_beams:=0"),
    ("cage_sim", "sim_node", "beam_width_deg:=45.0"),
    ("cage_sim", "sim_node", "marker_rate:=0.0"),
    ("cage_reactive_ddpg", "policy_node", "scan_timeout:=-1.0"),
    ("cage_reactive_ddpg", "policy_node", "max_invalid_fraction:=5.0"),
    ("cage_reactive_ddpg", "policy_node", "waypoint_radius:=-1.0"),
    ("cage_reactive_ddpg", "policy_node", "replan_after:=0"),
    ("cage_reactive_ddpg", "policy_node", "remembered_returns:=none"),
    ("cage_sim", "mission_client_node", "progress_every:=0"),
    ("cage_sim", "mission_client_node", "result_grace:=0.0"),
]


def _construct(pkg: str, exe: str, *params: str) -> str:
    """Build the node in this process over the real runtime with ``-p`` overrides; its refusal (the
    ValueError that ``run_node`` turns into one fatal line and exit 2), or "" if it started."""
    import importlib
    import rclpy
    import rclpy.node
    module = importlib.import_module(f"{pkg}.nodes.{exe}")
    cls = next(v for k, v in vars(module).items() if isinstance(v, type) and issubclass(v, rclpy.node.Node)
               and v.__module__ == module.__name__)
    rclpy.init(args=["--ros-args", *[a for p in params for a in ("-p", p)]])
    try:
        node = cls()
        node.destroy_node()
        return ""
    except ValueError as err:
        return str(err)
    finally:
        rclpy.try_shutdown()


@pytest.mark.parametrize("pkg, exe, arg", BAD_PARAMETERS)
def test_bad_parameters_are_refused_with_one_line_naming_them(pkg, exe, arg):
    extra = ("policy:=baseline",) if exe == "policy_node" else ()
    err = _construct(pkg, exe, arg, *extra)
    assert err.startswith(f"parameter {arg.split(':=')[0]}:=") and "\n" not in err, err


def test_remembered_returns_reaches_the_shield_and_the_baseline():
    """``remembered_returns`` is the perception setting of the shield's fallback (and of the
    baseline), as ``evaluate --remembered`` sets it offline; by default "cleared", with the node's
    own memory clearing what the sonar's beams (the policy's profile's width) see past."""
    import rclpy
    from cage_reactive_ddpg.nodes.policy_node import PolicyNode
    for value, extra, of in (("out_of_view", (), lambda n: n.driver.policy.fallback),
                             ("out_of_view", ("policy:=baseline",), lambda n: n.driver.policy),
                             (None, ("sensor:=fls",), lambda n: n.driver.policy.fallback)):
        chosen = ["-p", f"remembered_returns:={value}"] if value else []
        rclpy.init(args=["--ros-args", *chosen, *[a for p in extra for a in ("-p", p)]])
        try:
            node = PolicyNode()
            assert of(node).remembered == (value or "cleared")
            assert (node.driver.builder.cone is not None) == (value is None)     # fls: a memory to clear
            if value is None:
                assert node.driver.builder.cone == 0.5 * node.sonar.beam_width
            node.destroy_node()
        finally:
            rclpy.try_shutdown()


def _policy_copy(tmp_path, name, mutate):
    from cage_reactive_ddpg.policy import shipped_path
    w = shipped_path()
    meta = json.loads(w.with_suffix(".json").read_text())
    mutate(meta)
    dst = tmp_path / f"{name}.safetensors"
    shutil.copy(w, dst)
    dst.with_suffix(".json").write_text(json.dumps(meta))
    return dst


MALFORMED = {
    "activation": lambda m: m["network"].__setitem__("activation", "swish"),
    "layout_not_a_dict": lambda m: m.__setitem__("observation_layout", 5),
    "action_not_a_dict": lambda m: m.__setitem__("action", "x"),
    "turn_not_a_number": lambda m: m["action"].__setitem__("max_turn_deg", "x"),
    "network_null": lambda m: m.__setitem__("network", None),
}


@pytest.mark.parametrize("name", MALFORMED)
def test_malformed_policy_files_are_refused_with_one_line(tmp_path, name):
    err = _construct("cage_reactive_ddpg", "policy_node", f"policy:={_policy_copy(tmp_path, name, MALFORMED[name])}")
    assert err and "\n" not in err and str(tmp_path) in err, err
    if name == "activation":
        assert "swish" in err


def test_a_refused_start_is_one_fatal_line_and_exit_2(launch, tmp_path):
    nodes = [launch("cage_sim", "vehicle_node", "-p", "idle_publish_rate:=0.0"),
             launch("cage_reactive_ddpg", "policy_node", "-p",
                    f"policy:={_policy_copy(tmp_path, 'swish', MALFORMED['activation'])}")]
    for node in nodes:
        assert node.proc.wait(60) == 2, node.output
        assert len([ln for ln in node.output.splitlines() if "cannot start" in ln]) == 1, node.output
        assert_clean(node.output)


GOOD = [math.inf] * 72
BAD_SCANS = [   # (kwargs for faultlib.scan, words the refusal must say)
    (dict(ranges=GOOD, frame="sonar_link"), "frame"),
    (dict(ranges=GOOD, angle_min=math.pi), "rotated"),            # 180 deg: valid-looking and wrong
    (dict(ranges=GOOD, inc=-INC), "angle_increment"),
    (dict(ranges=GOOD, inc=float("nan")), "angle_increment"),
    (dict(ranges=[10.0] * 71), "71 ranges"),
    (dict(ranges=[10.0] * 100_000), "100000 ranges"),            # oversized
    (dict(ranges=[]), "0 ranges"),                               # empty
    (dict(ranges=[float("nan")] * 72), "invalid"),
    (dict(ranges=[-1.0] * 72), "invalid"),
]


def test_policy_node_refuses_garbage_scans_and_a_flood(launch, probe):
    setpoints = probe.listen(HeadingSetpoint, "/cage/heading_setpoint")
    events = probe.listen(MissionEvent, "/cage/mission_event")
    mission_pub = probe.node.create_publisher(Mission, "/cage/mission", LATCHED)
    odom_pub = probe.node.create_publisher(Odometry, "/cage/odom", 10)
    scan_pub = probe.node.create_publisher(LaserScan, "/cage/scan", qos_profile_sensor_data)
    node = launch("cage_reactive_ddpg", "policy_node", "-p", "policy:=baseline")
    assert probe.until(lambda: scan_pub.get_subscription_count() > 0, 20), node.output
    mission_pub.publish(mission_msg(1, Mission.ACTIVE, (20.0, 0.0), [(20.0, 0.0)], 0))
    assert probe.until(lambda: "following a route" in node.output, 10), node.output

    def decision(k: int, **kw) -> HeadingSetpoint:
        odom_pub.publish(odom(float(k), 0.0, 0.0, k * S))
        probe.until(lambda: False, 0.15)
        n = len(setpoints)
        scan_pub.publish(scan(k * S, **kw))
        assert probe.until(lambda: len(setpoints) > n, 5), (k, kw.keys(), node.output[-2000:])
        return setpoints[-1]

    odom_pub.publish(odom(0.0, 0.0, 0.0, 0))
    probe.until(lambda: False, 0.15)
    odom_pub.publish(odom(float("nan"), 0.0, 0.0, 0))            # garbage odometry: refused, not stored
    for k, (kw, words) in enumerate(BAD_SCANS):
        sp = decision(k, **kw)
        assert sp.source == HeadingSetpoint.SOURCE_FAILSAFE and sp.speed == 0.0 and sp.decision == k
        assert probe.until(lambda: any(e.step == k and words in e.detail for e in events), 5), (words, node.output)
    k = len(BAD_SCANS)
    sp = decision(k, ranges=[1e30] * 72)                         # huge but finite: far away, a real decision
    assert sp.source == HeadingSetpoint.SOURCE_BASELINE and sp.speed == 1.0 and abs(sp.heading) < 1e-6

    before, n = rss_mb(node.proc.pid), len(setpoints)           # 1 kHz for 1 s, all for the decided stamp
    t0 = time.monotonic()
    for i in range(1000):
        scan_pub.publish(scan(k * S, GOOD))
        if i % 50 == 0:
            probe.spin()
        while time.monotonic() < t0 + (i + 1) / 1000:
            pass
    probe.until(lambda: False, 1.0)
    assert node.proc.poll() is None
    assert len(setpoints) - n <= 40          # repeats re-sent at most every 50 ms, not echoed per scan
    assert rss_mb(node.proc.pid) - before < 30

    mission_pub.publish(mission_msg(2, Mission.ACTIVE, (0.0, 0.0), [], k * S))   # a failed plan: no route
    assert probe.until(lambda: "no more decisions" in node.output, 5), node.output
    n = len(setpoints)
    odom_pub.publish(odom(float(k + 1), 0.0, 0.0, (k + 1) * S))
    probe.until(lambda: False, 0.15)
    scan_pub.publish(scan((k + 1) * S, GOOD))
    probe.until(lambda: False, 0.5)
    assert len(setpoints) == n                 # it does not fly the old route
    assert_clean(node.output)


def test_vehicle_node_refuses_garbage_setpoints_and_a_flood(launch, probe):
    odoms = probe.listen(Odometry, "/cage/odom")
    mission_pub = probe.node.create_publisher(Mission, "/cage/mission", LATCHED)
    sp_pub = probe.node.create_publisher(HeadingSetpoint, "/cage/heading_setpoint", 10)
    node = launch("cage_sim", "vehicle_node", "-p", "scenario:=study2d", "-p", "seed:=1", "-p", "resume:=false",
                  "-p", "time_scale:=50.0")
    assert probe.until(lambda: sp_pub.get_subscription_count() > 0 and odoms, 20), node.output
    mission_pub.publish(mission_msg(1, Mission.ACTIVE, (0.0, 0.0), [(0.0, 0.0)], 0))
    assert probe.until(lambda: "mission 1" in node.output, 10), node.output
    x0, y0, yaw0 = odom_pose(odoms[0])
    t_now = lambda: stamp_ns(odoms[-1].header.stamp)

    for bad in (setpoint(0, float("nan")), setpoint(0, yaw0, float("inf")), setpoint(100 * S, yaw0),
                setpoint(0, yaw0, mission_id=7)):
        sp_pub.publish(bad)
    probe.until(lambda: False, 0.5)
    assert t_now() == 0 and odom_pose(odoms[-1])[:2] == (x0, y0)      # none of them moved it

    sp_pub.publish(setpoint(0, yaw0, 1e9))                 # absurd speed: clipped to the vehicle's 1 m/s
    assert probe.until(lambda: t_now() == S, 10)
    x1, y1, _ = odom_pose(odoms[-1])
    assert math.hypot(x1 - x0, y1 - y0) == pytest.approx(1.0, abs=0.05)
    sp_pub.publish(setpoint(S, yaw0, -5.0))                # negative speed: held, never reversed
    assert probe.until(lambda: t_now() == 2 * S, 10)
    assert math.hypot(*(a - b for a, b in zip(odom_pose(odoms[-1])[:2], (x1, y1)))) < 1e-9

    before = rss_mb(node.proc.pid)
    t0 = time.monotonic()
    for i in range(1000):                                   # 1 kHz for 1 s
        sp_pub.publish(setpoint(2 * S, yaw0 + (i % 7) * 0.1))
        if i % 50 == 0:
            probe.spin()
        while time.monotonic() < t0 + (i + 1) / 1000:
            pass
    probe.until(lambda: False, 1.0)
    assert node.proc.poll() is None and t_now() == 3 * S   # one decision flown for its one stamp
    assert rss_mb(node.proc.pid) - before < 30
    assert "non-finite" in node.output
    assert_clean(node.output)


def test_sim_node_refuses_garbage_odometry_and_a_flood(launch, probe):
    scans = probe.listen(LaserScan, "/cage/scan", qos_profile_sensor_data)
    events = probe.listen(MissionEvent, "/cage/mission_event")
    odom_pub = probe.node.create_publisher(Odometry, "/cage/odom", 10)
    mission_pub = probe.node.create_publisher(Mission, "/cage/mission", LATCHED)
    node = launch("cage_sim", "sim_node", "-p", "scenario:=study2d", "-p", "seed:=1")
    assert probe.until(lambda: odom_pub.get_subscription_count() > 0, 20), node.output
    mission_pub.publish(mission_msg(1, Mission.ACTIVE, (0.0, 0.0), [(float("nan"), 0.0)], 0))

    def send_garbage() -> bool:
        """Publish the bad odometry again until the node has said so: a publisher that has matched
        the node's reader can still be unknown to that reader for a while on a loaded machine, and
        what it sends until then is dropped by DDS, not refused by the node."""
        for bad in (odom(float("nan"), 0.0, 0.0, 0), odom(0.0, float("inf"), 0.0, 0), odom(1.0, 1.0, 0.0, -S)):
            odom_pub.publish(bad)
        probe.until(lambda: False, 0.2)
        return "non-finite" in node.output

    assert probe.until(send_garbage, 20), node.output
    assert scans == []
    odom_pub.publish(odom(0.0, 0.0, 0.0, 0))
    assert probe.until(lambda: len(scans) == 1, 5), node.output

    before, n = rss_mb(node.proc.pid), len(scans)
    t0 = time.monotonic()
    for i in range(1000):                                   # the same pose at 1 kHz for 1 s
        odom_pub.publish(odom(0.0, 0.0, 0.0, 0))
        if i % 50 == 0:
            probe.spin()
        while time.monotonic() < t0 + (i + 1) / 1000:
            pass
    probe.until(lambda: False, 1.0)
    assert node.proc.poll() is None
    assert len(scans) - n <= 40          # a repeat is rescanned at most every 50 ms
    assert rss_mb(node.proc.pid) - before < 30
    assert not [e for e in events if e.event != MissionEvent.STARTED]
    assert_clean(node.output)
