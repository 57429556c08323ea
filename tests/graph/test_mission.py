"""Whole-graph missions: the launch-free script, graph-vs-offline agreement, recording, start order."""
from __future__ import annotations

import json
import subprocess
import time

import pytest
import yaml

from cage_global_rrt.routes import RoutePlanner
from cage_reactive_ddpg.evaluate import load_driver
from cage_sim.controller import ArcController
from cage_sim.driver import Driver
from cage_sim.env import CageNavEnv
from cage_sim.mission import EnvConfig
from cage_sim.rollout import drive_episode

from graph_testlib import ROOT

SCRIPT = ROOT / "scripts" / "run_mission.sh"


# ``offline`` plans once per mission, so the comparisons with it switch policy_node's replan requests
# off; test_replanned_mission_in_the_graph_ends_as_offline compares with replans on both sides.
NO_REPLAN = ("--replan", "off")


def run_script(env, *args, timeout=240) -> tuple[int, dict | None, str]:
    proc = subprocess.run(["bash", str(SCRIPT), *args], env=env, cwd=ROOT, capture_output=True, text=True,
                          timeout=timeout)
    result = None
    for line in proc.stdout.splitlines():
        if line.startswith("RESULT "):
            result = json.loads(line[len("RESULT "):])
    return proc.returncode, result, proc.stdout + proc.stderr


def offline(policy, scenario="full_cage", seed=0, config: EnvConfig | None = None):
    """The graph's offline reference: the same Driver (observation, DVL drift, return motion) as policy_node."""
    config = config or EnvConfig()
    env = CageNavEnv(scenario, config, waypoint_fn=RoutePlanner())
    return drive_episode(env, Driver(policy, config.layout, config.vehicle), seed=seed)


FLS = ROOT / "ros2_ws/src/cage_reactive_ddpg/cage_reactive_ddpg/weights/policy_fls_s54.safetensors"   # fls's driver (policy.DRIVERS)
CURRENT = "cage?current=0.25&obstacles=small"   # 0.25 m/s inside the pen (varying), small obstacles


@pytest.mark.parametrize("weights, sensor", [(FLS, "fls"), (FLS.with_name("policy_mb360.safetensors"), "multibeam360"),
                                             (FLS.with_name("policy_mb360_cone5.safetensors"), ""),
                                             (FLS.with_name("policy_scanning.safetensors"), "scanning"),
                                             (None, "scanning")])
def test_profile_policy_in_a_current_in_the_graph_ends_as_offline(ros_env, tmp_path, weights, sensor):
    """A v2 policy (its profile's scan and/or memory + DVL velocity) behind the shield, sim_node sensor:=
    its profile, in a current: same outcome, same decisions, final pose within 1e-6 m of the offline
    Driver. The sonar's noise is off on both sides (the graph scans every odometry, offline every
    decision: the noise streams cannot be the same draws). The scanning policy observes its memory
    alone, so this also checks that policy_node places each beam of a sweep where the head fired it.
    ``policy_mb360_cone5`` learnt on the 5 deg beams multibeam360 had until session 40, and is run
    without ``--sensor``: run_mission.sh gives sim_node the profile and beams its file records, so
    the graph scans as the evaluator does. No file (``None``): ``--sensor scanning`` alone flies that
    profile's shipped driver (``policy.DRIVERS``) on both sides."""
    from dataclasses import replace
    from cage_reactive_ddpg.policy import env_config_for, shipped_path
    from cage_sim.sonar import make_sonar
    named = ["--policy", str(weights)] if weights else []
    rc, result, log = run_script(ros_env, *NO_REPLAN, "--out", str(tmp_path), *named, "--sensor", sensor,
                                 "--scenario", CURRENT, "--seed", "1", "--time-scale", "50.0", "--timeout", "120",
                                 "--sim-param", "noise_std:=0.0", "--sim-param", "dropout:=0.0")
    assert result is not None, log
    driver, _, meta = load_driver(str(weights) if weights else None, sensor=sensor or None)
    assert weights or f"{shipped_path('scanning').name} loaded" in (tmp_path / "logs" / "policy_node.log").read_text()
    config = replace(env_config_for(meta), sonar=make_sonar(env_config_for(meta).sonar, noise_std=0.0, dropout=0.0))
    ep = offline(driver, CURRENT, 1, config)
    assert ep.outcome == "goal" and ep.steps > 30          # a real mission, drifting 0.25 m/s
    assert result["outcome"] == ep.outcome and result["steps"] == ep.steps, log
    assert result["final"] == pytest.approx(ep.track[-1][:2], abs=1e-6)


def test_goal_in_sight_mission_in_the_graph_ends_as_offline(ros_env, tmp_path):
    """A mission on which the route tracker leaves the route's corner for the goal in sight
    (``route.RouteTracker``, session 46): sim_node's judge (the mission's own known map) and
    policy_node's tracker (the map from the ``map`` topic) switch at the same decision, so the
    outcome, the decisions and the final pose are the offline ones."""
    from cage_reactive_ddpg.policy import env_config_for
    rc, result, log = run_script(ros_env, *NO_REPLAN, "--out", str(tmp_path), "--scenario", CURRENT, "--seed", "14",
                                 "--time-scale", "50.0", "--timeout", "120")
    assert result is not None, log
    driver, _, meta = load_driver(None)
    config = env_config_for(meta)
    env = CageNavEnv(CURRENT, config, waypoint_fn=RoutePlanner())
    ep = drive_episode(env, Driver(driver, config.layout, config.vehicle), seed=14)
    assert env.mission.tracker.sighted and ep.outcome == "goal"          # offline, the rule fired
    assert "goal in sight" in (tmp_path / "logs" / "policy_node.log").read_text()   # and in the graph
    assert result["outcome"] == ep.outcome and result["steps"] == ep.steps, log
    assert result["final"] == pytest.approx(ep.track[-1][:2], abs=1e-6)


@pytest.mark.parametrize("name, sensor", [("policy", ""), ("policy_fls_near_cleared", "fls")])
def test_residual_policy_raw_in_a_current_in_the_graph_ends_as_offline(ros_env, tmp_path, name, sensor):
    """A residual policy without the shield (``--shield off``): policy_node gives it the flown
    baseline's action as its base (drift from the odometry twist, the returns' motion, the final
    approach) through ``cage_sim.driver``, as offline; same outcome, decisions and final pose. The
    default (its base counts every remembered return) and an fls policy whose base reads the
    cleared memory (session 55: policy_node's own memory, cleared as the scans come in)."""
    weights = FLS.with_name(f"{name}.safetensors")
    named = ["--sensor", sensor] if sensor else []
    rc, result, log = run_script(ros_env, *NO_REPLAN, "--out", str(tmp_path), "--policy", str(weights), *named,
                                 "--shield", "off", "--scenario", CURRENT, "--seed", "1", "--time-scale", "50.0",
                                 "--timeout", "120", "--sim-param", "noise_std:=0.0", "--sim-param", "dropout:=0.0")
    assert result is not None, log
    from dataclasses import replace
    from cage_reactive_ddpg.policy import env_config_for
    from cage_sim.sonar import make_sonar
    driver, _, meta = load_driver(str(weights), shield=False, sensor=sensor or None)
    assert driver.residual_base is not None and driver.residual_base.remembered == ("cleared" if sensor else "all")
    config = env_config_for(meta)
    ep = offline(driver, CURRENT, 1, replace(config, sonar=make_sonar(config.sonar, noise_std=0.0, dropout=0.0)))
    assert ep.outcome == "goal" and ep.steps > 30
    assert result["outcome"] == ep.outcome and result["steps"] == ep.steps, log
    assert result["final"] == pytest.approx(ep.track[-1][:2], abs=1e-6)


def test_scanning_head_mission_in_the_graph_ends_as_offline(ros_env, tmp_path):
    """sim_node sensor:=scanning (one beam per 22 ms, a 4 s sweep published oldest beam first, so the
    first sweep starts before t = 0): policy_node decides from the first decision on and the mission
    ends as offline (same outcome, decisions and final pose). Before, the first sweep's negative stamp
    and a 1 ns rounding left the graph waiting forever; then a mission that reached sim_node after the
    first odometry left its scanning head unprimed (tests/faults/test_sim_scanning_start.py)."""
    from cage_sim.sonar import make_sonar
    rc, result, log = run_script(ros_env, *NO_REPLAN, "--out", str(tmp_path), "--policy", "baseline",
                                 "--sensor", "scanning", "--scenario", "cage", "--seed", "1", "--time-scale", "20.0",
                                 "--timeout", "120", "--sim-param", "noise_std:=0.0", "--sim-param", "dropout:=0.0")
    assert result is not None and result["steps"] > 0, log
    config = EnvConfig(sonar=make_sonar("scanning", noise_std=0.0, dropout=0.0))
    ep = offline(ArcController(config.layout), "cage", 1, config)
    assert result["outcome"] == ep.outcome and result["steps"] == ep.steps, log
    assert result["final"] == pytest.approx(ep.track[-1][:2], abs=1e-6)


def test_replanned_mission_in_the_graph_ends_as_offline(ros_env, tmp_path):
    """Replans on both sides: policy_node asks when 8 m off the route and, in lockstep, holds that
    decision until the new plan arrives; offline (``run_missions(replan=...)``, ``evaluate --replan
    on``) replans at the same decision. cage seed 110: one replan, goal after 45 decisions instead of
    the 64 of one plan per mission; the graph flies the same decisions to within 1e-6 m."""
    from cage_reactive_ddpg.evaluate import run_missions
    from cage_reactive_ddpg.policy import env_config_for
    rc, result, log = run_script(ros_env, "--out", str(tmp_path), "--scenario", "cage", "--seed", "110",
                                 "--timeout", "120")
    assert result is not None, log
    driver, _, meta = load_driver(None)
    config = env_config_for(meta)
    planner = RoutePlanner()
    env = CageNavEnv("cage", config, waypoint_fn=planner)
    env.reset(seed=110)
    once, again = (run_missions(driver, [env.mission.scenario], config, keep_tracks=1, replan=r)[0]
                   for r in (None, planner))
    assert again.replans >= 1 and again.steps != once.steps          # the replan changed the mission
    assert "asking for a new plan" in (tmp_path / "logs" / "policy_node.log").read_text()
    assert result["outcome"] == again.outcome and result["steps"] == again.steps, log
    assert result["final"] == pytest.approx(again.track[-1][:2], abs=1e-6)


def test_a_policy_of_another_profile_is_refused_by_name(ros_env, tmp_path):
    rc, result, log = run_script(ros_env, "--out", str(tmp_path), "--policy", str(FLS), "--sensor", "study",
                                 "--timeout", "30")
    assert rc == 70 and "trained for sensor profile 'fls'" in log and "'study'" in log, log


@pytest.mark.parametrize("policy", ["shipped", "baseline"])
def test_full_cage_mission_in_the_graph_ends_as_offline(ros_env, tmp_path, policy):
    args = ["--out", str(tmp_path), "--timeout", "150"] + (["--policy", "baseline"] if policy == "baseline" else [])
    rc, result, log = run_script(ros_env, *NO_REPLAN, *args)
    assert result is not None, log
    from cage_reactive_ddpg.policy import env_config_for
    driver, _, meta = load_driver("baseline" if policy == "baseline" else None)   # shipped: behind the shield
    ep = offline(driver, config=env_config_for(meta) if meta else None)     # the policy's own layout
    assert ep.outcome == "goal"
    assert rc == 0 and result["outcome"] == "goal", log
    assert result["steps"] == ep.steps
    assert result["final"] == pytest.approx(ep.track[-1][:2], abs=1e-6)
    assert (tmp_path / "mission_track.png").stat().st_size > 10_000


def test_mission_can_be_recorded_to_mcap(ros_env, tmp_path):
    bag = tmp_path / "bag"
    rc, result, log = run_script(ros_env, "--out", str(tmp_path), "--policy", "baseline", "--record", str(bag),
                                 "--scenario", "study2d", "--seed", "3")
    assert rc == 0, log
    mcaps = list(bag.glob("*.mcap"))
    assert len(mcaps) == 1 and (bag / "metadata.yaml").is_file()

    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore
    with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        scans = [c for c in reader.connections if c.topic == "/cage/scan"]
        _, _, raw = next(reader.messages(connections=scans))
        scan = reader.deserialize(raw, scans[0].msgtype)
    assert len(scan.ranges) == 72
    assert counts["/cage/scan"] > result["steps"] and counts["/cage/heading_setpoint"] >= result["steps"]
    assert counts["/cage/map"] == 1 and counts["/cage/mission_event"] >= 1

    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    seen: dict[str, list] = {}
    with open(mcaps[0], "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, _, msg in reader.iter_decoded_messages(topics=["/cage/map", "/cage/mission_event"]):
            seen.setdefault(channel.topic, []).append(msg)
    assert seen["/cage/map"][0].net_radius == 30.0
    events = [e.event for e in seen["/cage/mission_event"]]
    assert events[0] == 0 and events[-1] == 2, events          # STARTED ... GOAL_REACHED
    assert all(e.mission_id == result["mission_id"] for e in seen["/cage/mission_event"])

    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    qos = {t["topic_metadata"]["name"]: t["topic_metadata"]["offered_qos_profiles"] for t in meta["topics_with_message_count"]}
    assert qos["/cage/map"][0]["durability"] in (1, "transient_local")      # latched topics replay latched
    assert qos["/cage/scan"][0]["reliability"] in (2, "best_effort")


def test_start_order_does_not_matter(launch, ros_env, tmp_path):
    """Client, policy and navigator first, the world last: latched topics, the action client waiting for
    its server and re-sent plan requests still bring it together."""
    shared = ["--params-file", str(ROOT / "ros2_ws/src/cage_sim/config/graph.yaml"), "-p", "scenario:=study2d",
              "-p", "seed:=5", "-p", "time_scale:=50.0"]
    client = launch("cage_sim", "mission_client", *shared, "-p", "timeout:=90.0", "-p", f"png:={tmp_path}/t.png")
    launch("cage_reactive_ddpg", "policy_node", *shared, "-p", "policy:=baseline")
    launch("cage_sim", "navigator_node", *shared)
    time.sleep(2.0)
    launch("cage_global_rrt", "rrt_node", "--params-file", str(ROOT / "ros2_ws/src/cage_global_rrt/config/rrt.yaml"),
           *shared)
    time.sleep(1.0)
    launch("cage_sim", "sim_node", *shared)
    time.sleep(1.0)
    launch("cage_sim", "vehicle_node", *shared)
    rc = client.proc.wait(timeout=120)
    out = client.output
    assert rc == 0 and "outcome: goal" in out, out
    ep = offline(ArcController(), "study2d", 5)
    result = json.loads(out.split("RESULT ", 1)[1].splitlines()[0])
    assert result["steps"] == ep.steps
