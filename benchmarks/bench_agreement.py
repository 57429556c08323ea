"""Graph vs offline: the same seeded missions through the node graph and through the offline env.

Each mission runs the launch-free graph (scripts/run_mission.sh: five node processes over DDS in the
namespace /cage; the goal goes through the navigator's Navigate action) and
the offline env (CageNavEnv with the same planner options and policy) on the same scenario seed.
Prints outcome rates side by side, the share of missions with the same outcome and the same number
of decisions, and ends with one JSON line. Target (issue 6): rates within 2 points.

    .venv/bin/python benchmarks/bench_agreement.py [--missions 100] [--scenario cage] [--policy baseline]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUTCOMES = ("goal", "collision", "wander", "timeout")


def graph_mission(scenario: str, seed: int, policy: str, time_scale: float) -> dict:
    with tempfile.TemporaryDirectory() as out:
        cmd = ["bash", str(ROOT / "scripts/run_mission.sh"), "--scenario", scenario, "--seed", str(seed),
               "--out", out, "--png", "", "--time-scale", str(time_scale), "--timeout", "180"]
        if policy:
            cmd += ["--policy", policy]
        env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}")
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=ROOT)
    for line in proc.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[7:])
    return {"outcome": "error", "steps": 0, "detail": proc.stderr[-400:]}


def offline_missions(scenario: str, seeds: list[int], policy: str) -> list:
    from cage_global_rrt.routes import RoutePlanner
    from cage_reactive_ddpg.evaluate import load_driver
    from cage_sim.env import CageNavEnv
    from cage_sim.rollout import run_episode
    pol, _, _ = load_driver(policy or None)   # a learned policy behind the shield, as the node runs it
    env = CageNavEnv(scenario, waypoint_fn=RoutePlanner())
    return [run_episode(env, pol, seed=s) for s in seeds]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--missions", type=int, default=100)
    ap.add_argument("--scenario", default="cage")
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--policy", default="", help="policy file, 'baseline', or empty for the shipped weights")
    ap.add_argument("--time-scale", type=float, default=100.0)
    args = ap.parse_args()
    seeds = list(range(args.first_seed, args.first_seed + args.missions))
    t0 = time.perf_counter()
    offline = offline_missions(args.scenario, seeds, args.policy)
    t_off = time.perf_counter() - t0
    graph = []
    t0 = time.perf_counter()
    for i, s in enumerate(seeds):
        graph.append(graph_mission(args.scenario, s, args.policy, args.time_scale))
        if (i + 1) % 10 == 0 or i + 1 == len(seeds):
            same = sum(g["outcome"] == o.outcome for g, o in zip(graph, offline))
            print(f"  {i + 1}/{len(seeds)} missions, {same} same outcome, {time.perf_counter() - t0:.0f} s",
                  file=sys.stderr, flush=True)
    t_graph = time.perf_counter() - t0
    n = len(seeds)
    g_counts = Counter(g["outcome"] for g in graph)
    o_counts = Counter(o.outcome for o in offline)
    same_outcome = sum(g["outcome"] == o.outcome for g, o in zip(graph, offline))
    same_steps = sum(g["outcome"] == o.outcome and g["steps"] == o.steps for g, o in zip(graph, offline))
    print(f"\n{n} missions of '{args.scenario}', policy {args.policy or 'shipped'}")
    print(f"{'outcome':10s} {'graph %':>8s} {'offline %':>10s} {'diff (points)':>14s}")
    diffs = {}
    for k in OUTCOMES + (("error",) if g_counts["error"] else ()):
        gp, op = 100 * g_counts[k] / n, 100 * o_counts[k] / n
        diffs[k] = gp - op
        print(f"{k:10s} {gp:8.1f} {op:10.1f} {gp - op:14.1f}")
    print(f"same outcome: {same_outcome}/{n}; same outcome and decisions: {same_steps}/{n}")
    print(f"time: graph {t_graph:.0f} s ({t_graph / n:.1f} s per mission incl. start-up), offline {t_off:.1f} s")
    mismatches = [{"seed": s, "graph": g["outcome"], "graph_steps": g["steps"], "offline": o.outcome,
                   "offline_steps": o.steps} for s, g, o in zip(seeds, graph, offline)
                  if g["outcome"] != o.outcome or g["steps"] != o.steps]
    print(json.dumps({"missions": n, "scenario": args.scenario, "policy": args.policy or "shipped",
                      "graph": dict(g_counts), "offline": dict(o_counts), "diff_points": diffs,
                      "same_outcome": same_outcome, "same_outcome_and_steps": same_steps,
                      "mismatches": mismatches[:20], "graph_s": t_graph, "offline_s": t_off}))


if __name__ == "__main__":
    main()
