"""Graph vs offline: the same seeded missions through the node graph and through the offline env.

Each mission runs the launch-free graph (scripts/run_mission.sh: five node processes over DDS in the
namespace /cage; the goal goes through the navigator's Navigate action) and
the offline env (CageNavEnv with the same planner options and policy) on the same scenario seed.
Prints outcome rates side by side, the share of missions with the same outcome and the same number
of decisions, and ends with one JSON line. Target (issue 6): rates within 2 points.

    .venv/bin/python benchmarks/bench_agreement.py [--missions 100] [--scenario cage] [--policy baseline]
    .venv/bin/python benchmarks/bench_agreement.py --missions 20 --scenario 'cage?current=0.5&obstacles=small' \
        --policy <weights/policy_fls_guided.safetensors> --sensor fls --shield off     # a set with collisions

Both sides decide through ``cage_sim.driver`` (the offline side with ``rollout.drive_episode``) with the
policy's own sensor profile and observation. ``--noise off`` (default) switches the sonar's noise,
dropout and clutter off on both sides: the graph scans every odometry and offline every decision, so
their noise draws cannot be the same. ``--replan on`` lets policy_node ask for new plans (no progress
for ``replan_after`` decisions, ``replan_offset`` off the route; in lockstep it holds that decision
until the plan arrives) and the offline side replan at the same decisions (``evaluate --replan on``);
``--replan off`` (default) switches both off: one plan per mission.
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


def graph_mission(scenario: str, seed: int, policy: str, time_scale: float, sensor: str = "", shield: str = "on",
                  noise: str = "off", extra: tuple[str, ...] = ()) -> dict:
    """One mission through the graph (``extra``: more run_mission.sh arguments); its RESULT line."""
    with tempfile.TemporaryDirectory() as out:
        cmd = ["bash", str(ROOT / "scripts/run_mission.sh"), "--scenario", scenario, "--seed", str(seed),
               "--out", out, "--png", "", "--time-scale", str(time_scale), "--timeout", "180"]
        if policy:
            cmd += ["--policy", policy]
        if sensor:
            cmd += ["--sensor", sensor]
        if shield == "off":
            cmd += ["--shield", "off"]
        if noise == "off":
            cmd += [a for k in ("noise_std", "dropout", "clutter") for a in ("--sim-param", f"{k}:=0.0")]
        cmd += list(extra)
        env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}")
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=ROOT)
    for line in proc.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[7:])
    return {"outcome": "error", "steps": 0, "detail": proc.stderr[-400:]}


def offline_missions(scenario: str, seeds: list[int], policy: str, sensor: str = "", shield: str = "on",
                     noise: str = "off", replan: str = "off") -> list:
    from dataclasses import replace
    from cage_global_rrt.routes import RoutePlanner
    from cage_reactive_ddpg.evaluate import load_driver
    from cage_reactive_ddpg.policy import env_config_for
    from cage_sim.driver import Driver
    from cage_sim.env import CageNavEnv
    from cage_sim.mission import EnvConfig
    from cage_sim.rollout import drive_episode
    from cage_sim.sonar import make_sonar
    # a learned policy behind the shield unless --shield off, as the node runs it
    pol, _, meta = load_driver(policy or None, shield == "on", sensor or None)
    config = env_config_for(meta) if meta else EnvConfig(sonar=sensor or "study")
    if noise == "off":
        config = replace(config, sonar=make_sonar(config.sonar, noise_std=0.0, dropout=0.0, clutter=0.0))
    planner = RoutePlanner()
    env = CageNavEnv(scenario, config, waypoint_fn=planner)
    if replan == "off":
        return [drive_episode(env, Driver(pol, config.layout, config.vehicle), seed=s) for s in seeds]
    from cage_reactive_ddpg.evaluate import run_missions
    scs = []
    for s in seeds:                       # the env's seeded scenario with its planned route, as the graph's
        env.reset(seed=s)
        scs.append(env.mission.scenario)
    return run_missions(pol, scs, config, replan=planner)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--missions", type=int, default=100)
    ap.add_argument("--scenario", default="cage")
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--policy", default="", help="policy file, 'baseline', or empty for the shipped weights (--sensor's driver, policy.DRIVERS)")
    ap.add_argument("--time-scale", type=float, default=100.0)
    ap.add_argument("--sensor", default="", help="sonar profile (default: the policy's; study for the baseline)")
    ap.add_argument("--shield", default="on", choices=["on", "off"], help="off: the raw learned policy")
    ap.add_argument("--noise", default="off", choices=["on", "off"], help="sonar noise/dropout/clutter (see above)")
    ap.add_argument("--replan", default="off", choices=["on", "off"], help="policy_node's replan requests (see above)")
    args = ap.parse_args()
    seeds = list(range(args.first_seed, args.first_seed + args.missions))
    t0 = time.perf_counter()
    offline = offline_missions(args.scenario, seeds, args.policy, args.sensor, args.shield, args.noise, args.replan)
    t_off = time.perf_counter() - t0
    graph = []
    t0 = time.perf_counter()
    for i, s in enumerate(seeds):
        graph.append(graph_mission(args.scenario, s, args.policy, args.time_scale, args.sensor, args.shield,
                                   args.noise, ("--replan", args.replan)))
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
    shipped = f"shipped ({args.sensor}'s driver)" if args.sensor else "shipped"
    print(f"\n{n} missions of '{args.scenario}', policy {args.policy or shipped}, sensor "
          f"{args.sensor or 'the policy s'}, shield {args.shield}, sonar noise {args.noise}")
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
                      "sensor": args.sensor, "shield": args.shield, "noise": args.noise,
                      "graph": dict(g_counts), "offline": dict(o_counts), "diff_points": diffs,
                      "same_outcome": same_outcome, "same_outcome_and_steps": same_steps,
                      "mismatches": mismatches[:20], "graph_s": t_graph, "offline_s": t_off}))


if __name__ == "__main__":
    main()
