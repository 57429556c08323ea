"""Action round trip across processes: send_goal -> accepted, and send_goal -> result.

The benchmark process runs an ActionClient; a second process (this file with `--server`) runs an
ActionServer (`example_interfaces/action/Fibonacci`, goal callback accepts, the execute callback
succeeds at once).  Each goal is sent only after the previous one finished, so the figures are one round
trip each: SendGoal request -> response (accepted), then GetResult request -> response.  Both sides
use the project's runtime over Cyclone DDS (or real rclpy on a ROS 2 machine).  Prints a table, then
one JSON line.

    .venv/bin/python benchmarks/bench_action.py [--goals 500] [--warmup 20]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np


def serve() -> None:
    import rclpy
    from example_interfaces.action import Fibonacci
    from rclpy.action import ActionServer
    from rclpy.executors import ExternalShutdownException

    def execute(goal_handle):
        goal_handle.succeed()
        return Fibonacci.Result(sequence=[0, 1][:max(goal_handle.request.order, 0)])

    rclpy.init()
    node = rclpy.create_node('bench_action_server')
    ActionServer(node, Fibonacci, 'bench_fibonacci', execute)
    print('READY', flush=True)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


def pct(values: list, q: float) -> float:
    return float(np.percentile(values, q)) if values else float('nan')


def measure(goals: int, warmup: int) -> dict:
    import rclpy
    from example_interfaces.action import Fibonacci
    from rclpy.action import ActionClient
    from rclpy.executors import SingleThreadedExecutor

    domain = os.getpid() % 200 + 20
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), PYTHONUNBUFFERED='1')
    server = subprocess.Popen([sys.executable, __file__, '--server'], env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True)
    try:
        assert server.stdout is not None and 'READY' in server.stdout.readline()
        rclpy.init(domain_id=domain)
        node = rclpy.create_node('bench_action_client')
        client = ActionClient(node, Fibonacci, 'bench_fibonacci')
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        if not client.wait_for_server(timeout_sec=30):
            raise SystemExit('the action server did not come up in 30 s')
        accepted_ms: list[float] = []
        result_ms: list[float] = []
        for i in range(warmup + goals):
            t0 = time.perf_counter()
            sent = client.send_goal_async(Fibonacci.Goal(order=2))
            while not sent.done():
                executor.spin_once(timeout_sec=1.0)
            t1 = time.perf_counter()
            handle = sent.result()
            if not handle.accepted:
                raise SystemExit('goal rejected')
            result = handle.get_result_async()
            while not result.done():
                executor.spin_once(timeout_sec=1.0)
            t2 = time.perf_counter()
            if i >= warmup:
                accepted_ms.append((t1 - t0) * 1e3)
                result_ms.append((t2 - t0) * 1e3)
        node.destroy_node()
        rclpy.shutdown()
    finally:
        server.terminate()
        server.wait(10)
    return {'goals': goals,
            'accepted_ms': {'p50': pct(accepted_ms, 50), 'p90': pct(accepted_ms, 90),
                            'p99': pct(accepted_ms, 99), 'max': max(accepted_ms)},
            'result_ms': {'p50': pct(result_ms, 50), 'p90': pct(result_ms, 90),
                          'p99': pct(result_ms, 99), 'max': max(result_ms)}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--goals', type=int, default=500)
    parser.add_argument('--warmup', type=int, default=20)
    parser.add_argument('--server', action='store_true', help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.server:
        serve()
        return
    out = measure(args.goals, args.warmup)
    print(f"\n{'round trip':<28} {'p50 ms':>8} {'p90 ms':>8} {'p99 ms':>8} {'max ms':>8}")
    for label, key in (('send_goal -> accepted', 'accepted_ms'), ('send_goal -> result', 'result_ms')):
        r = out[key]
        print(f"{label:<28} {r['p50']:8.3f} {r['p90']:8.3f} {r['p99']:8.3f} {r['max']:8.3f}")
    print(f"({out['goals']} goals, one at a time, across two processes)")
    print(json.dumps({'bench_action': out}))


if __name__ == '__main__':
    main()
