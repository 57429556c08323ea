"""Scan published -> heading setpoint received, across processes, through the real policy_node.

The benchmark process publishes the known map (as sim_node does: the shield keeps clear of it) and a
mission (the navigator's Mission message: id and route), then odometry + LaserScan at a fixed rate (10 Hz and 100 Hz by
default) and times each HeadingSetpoint the policy node (own process, shipped DDPG weights, free-run
mode: one decision per scan) sends back. Prints p50/p90/p99/max per rate and per time window (to show
the tail stays flat), and the policy node's resident memory at the start and end (growth check).
Ends with one JSON line. Targets (issue 6): p99 <= 5 ms, flat over a 10-minute run, no memory growth.

    .venv/bin/python benchmarks/bench_latency.py [--duration 60] [--rates 10 100] [--policy baseline] [--goal-ahead 8]
        [--goal-bearing 180] [--param goal_search:=false]

``--goal-ahead M --goal-bearing 180``: the goal M m behind, where no 10-decision manoeuvre of the
controller's gets (a half turn and back), so the shield's goal search runs at every decision: its
worst case. ``--param NAME:=VALUE`` (repeatable) passes a parameter to policy_node.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


def pct(a, q) -> float:
    return float(np.percentile(a, q)) if len(a) else float("nan")


def run_rate(rate: float, duration: float, policy: str, windows: int, goal_ahead: float = 0.0,
             goal_bearing: float = 0.0, params: tuple[str, ...] = ()) -> dict:
    import rclpy
    from cage_planner_msgs.msg import CageMap, HeadingSetpoint, Mission
    from nav_msgs.msg import Odometry
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
    from sensor_msgs.msg import LaserScan

    from cage_sim.ros_convert import mission_msg, scan_msg, time_msg, world_to_map, yaw_to_quaternion
    from cage_sim.scenarios import builtin_file
    from cage_sim.sonar import SonarModel

    domain = (os.getpid() % 150) + 60 + int(rate) % 7
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), PYTHONUNBUFFERED="1")
    args = ["ros2", "run", "cage_reactive_ddpg", "policy_node", "--ros-args", "-r", "__ns:=/cage", "-p", "lockstep:=false",
            "-p", "scan_timeout:=5.0"] + (["-p", f"policy:={policy}"] if policy else [])
    args += [a for p in params for a in ("-p", p)]
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env['PATH']}"
    node_proc = subprocess.Popen(args, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    rclpy.init(domain_id=domain)
    node = rclpy.create_node("latency_probe")
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    mission_pub = node.create_publisher(Mission, "/cage/mission", latched)
    map_pub = node.create_publisher(CageMap, "/cage/map", latched)   # as sim_node: the shield's known map
    odom_pub = node.create_publisher(Odometry, "/cage/odom", 10)
    scan_pub = node.create_publisher(LaserScan, "/cage/scan", qos_profile_sensor_data)
    sent: dict[int, float] = {}
    lat: list[tuple[float, float]] = []

    def on_setpoint(msg: HeadingSetpoint) -> None:
        t = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        if t in sent:
            lat.append((time.perf_counter(), time.perf_counter() - sent.pop(t)))
    node.create_subscription(HeadingSetpoint, "/cage/heading_setpoint", on_setpoint, 10)

    sc = builtin_file("full_cage.yaml")
    sonar = SonarModel()
    goal = sc.goal
    if goal_ahead > 0:   # the goal that many metres off: every decision is one of the final approach
        bearing = sc.start[2] + math.radians(goal_bearing)
        goal = (sc.start[0] + goal_ahead * math.cos(bearing), sc.start[1] + goal_ahead * math.sin(bearing))
    map_pub.publish(world_to_map(sc.world, 0))
    mission_pub.publish(mission_msg(1, Mission.ACTIVE, goal, [sc.start[:2], goal], 0))
    deadline = time.monotonic() + 30
    while scan_pub.get_subscription_count() == 0 and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    time.sleep(1.0)
    x, y, yaw = sc.start
    ranges = sonar.scan(sc.world, x, y, yaw)
    odom = Odometry()
    odom.header.frame_id = "map"
    odom.pose.pose.position.x, odom.pose.pose.position.y = x, y
    odom.pose.pose.orientation = yaw_to_quaternion(yaw)
    period_ns = 1_000_000_000  # one decision per sim second (1 m at 1 m/s)
    k, t0 = 0, time.perf_counter()
    mem = [(0.0, rss_mb(node_proc.pid))]
    next_mem = 10.0

    def tick() -> None:
        nonlocal k, next_mem
        k += 1
        odom.header.stamp = time_msg(k * period_ns)
        odom_pub.publish(odom)
        scan = scan_msg(ranges, sonar, k * period_ns)
        sent[k * period_ns] = time.perf_counter()
        scan_pub.publish(scan)
        el = time.perf_counter() - t0
        if el >= next_mem:
            mem.append((el, rss_mb(node_proc.pid)))
            next_mem += 10.0
        if int(el) % 10 == 0 and k % int(rate * 10) == 0:
            print(f"  {rate:g} Hz: {el:5.0f} s, {len(lat)} answers", file=sys.stderr, flush=True)
    node.create_timer(1.0 / rate, tick)
    while time.perf_counter() - t0 < duration:
        rclpy.spin_once(node, timeout_sec=0.01)
    end = time.perf_counter()
    node.destroy_node()
    rclpy.shutdown()
    node_proc.send_signal(signal.SIGINT)
    node_proc.wait(10)
    ms = np.array([v for _, v in lat]) * 1000.0
    ts = np.array([t - t0 for t, _ in lat])
    win = []
    for i in range(windows):
        a, b = i * duration / windows, (i + 1) * duration / windows
        sel = ms[(ts >= a) & (ts < b)]
        win.append({"from_s": round(a), "p50": round(pct(sel, 50), 3), "p99": round(pct(sel, 99), 3)})
    return {"rate_hz": rate, "sent": k, "answered": len(ms), "lost": k - len(ms),
            "p50_ms": pct(ms, 50), "p90_ms": pct(ms, 90), "p99_ms": pct(ms, 99), "max_ms": float(ms.max()) if len(ms) else None,
            "windows": win, "rss_start_mb": mem[1][1] if len(mem) > 1 else mem[0][1], "rss_end_mb": rss_mb_safe(mem),
            "seconds": end - t0}


def rss_mb_safe(mem) -> float:
    return mem[-1][1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=60.0, help="seconds per rate (600 for the 10-minute run)")
    ap.add_argument("--rates", type=float, nargs="+", default=[10.0, 100.0])
    ap.add_argument("--policy", default="", help="policy file, 'baseline', or empty for the shipped weights")
    ap.add_argument("--windows", type=int, default=6)
    ap.add_argument("--goal-ahead", type=float, default=0.0,
                    help="put the goal this many m ahead of the vehicle (0: the scenario's, far away): every "
                         "decision is then one of the final approach, where the shield's sure approach runs")
    ap.add_argument("--goal-bearing", type=float, default=0.0,
                    help="with --goal-ahead: the goal's bearing from the heading, deg left (180: behind, where "
                         "the shield's goal search runs at every decision)")
    ap.add_argument("--param", action="append", default=[], metavar="NAME:=VALUE",
                    help="a policy_node parameter (repeatable), e.g. goal_search:=false")
    args = ap.parse_args()
    results = []
    for rate in args.rates:
        print(f"measuring {rate:g} Hz for {args.duration:g} s ...", file=sys.stderr, flush=True)
        results.append(run_rate(rate, args.duration, args.policy, args.windows, args.goal_ahead, args.goal_bearing,
                                tuple(args.param)))
    print(f"\n{'rate':>6} {'sent':>7} {'lost':>5} {'p50 ms':>8} {'p90 ms':>8} {'p99 ms':>8} {'max ms':>8} "
          f"{'RSS start':>10} {'RSS end':>8}   target p99 <= 5 ms")
    for r in results:
        print(f"{r['rate_hz']:6g} {r['sent']:7d} {r['lost']:5d} {r['p50_ms']:8.3f} {r['p90_ms']:8.3f} "
              f"{r['p99_ms']:8.3f} {r['max_ms']:8.3f} {r['rss_start_mb']:9.1f}M {r['rss_end_mb']:7.1f}M")
        print("        p99 per window: " + ", ".join(f"{w['from_s']}s {w['p99']:.2f}" for w in r["windows"]))
    print(json.dumps({"latency": results}))


if __name__ == "__main__":
    main()
