"""Simulation-core throughput: sonar scans/s (single and batched) and env steps/s.

Scene: the study's cage (30 m net, 20 known 2 x 2 m squares) plus 10 unknown obstacles, 72 beams,
20 m range. Targets (issue 2): >= 50,000 scans/s batched, <= 30 us per single scan, on one core
(numba kernels run on one thread). Prints a table, then one JSON line of the figures.

    .venv/bin/python benchmarks/bench_sim.py [--seconds 2] [--batch 1024]
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from cage_sim.controller import ArcController
from cage_sim.env import CageNavEnv, CageNavVecEnv
from cage_sim.scenarios import CageParams, generate_cage
from cage_sim.sonar import SonarModel


def rate(fn, seconds: float, per_call: int = 1) -> float:
    fn()  # warm up (numba compile / caches)
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        fn()
        n += 1
    return n * per_call / (time.perf_counter() - t0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--batch", type=int, default=1024)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    sc = generate_cage(rng, CageParams(n_unknown=10))
    world, sonar = sc.world, SonarModel()
    poses = np.c_[rng.uniform(-18, 18, (args.batch, 2)), rng.uniform(-3.14, 3.14, args.batch)]
    x, y, yaw = poses[0]

    single = rate(lambda: sonar.scan(world, x, y, yaw), args.seconds)
    batched = rate(lambda: sonar.scan_batch([world], poses), args.seconds, args.batch)
    worlds = [generate_cage(np.random.default_rng(i)).world for i in range(64)]
    many = np.resize(poses, (64, 3))
    multi = rate(lambda: sonar.scan_batch(worlds, many), args.seconds, 64)

    env = CageNavEnv("cage")
    env.reset(seed=0)
    zero = np.zeros(1, dtype=np.float32)

    def env_step():
        _, _, term, trunc, _ = env.step(zero)
        if term or trunc:
            env.reset()
    env_rate = rate(env_step, args.seconds)
    venv = CageNavVecEnv(32, "cage", seed=0)
    venv.reset()
    acts = np.zeros(32)
    vec_rate = rate(lambda: venv.step(acts), args.seconds, 32)
    ctrl, obs = ArcController(), env.reset(seed=1)[0]
    ctrl_rate = rate(lambda: ctrl.act(obs), args.seconds)

    figures = {
        "scan_single_us": 1e6 / single, "scans_per_s_single": single,
        "scans_per_s_batched_one_world": batched, "scans_per_s_batched_64_worlds": multi,
        "env_steps_per_s": env_rate, "vec_env_steps_per_s_32": vec_rate,
        "arc_controller_decisions_per_s": ctrl_rate,
    }
    print(f"{'figure':34s} {'value':>12s}  target")
    targets = {"scan_single_us": "<= 30", "scans_per_s_batched_one_world": ">= 50000"}
    for k, v in figures.items():
        print(f"{k:34s} {v:12.1f}  {targets.get(k, '')}")
    print(json.dumps({k: round(v, 2) for k, v in figures.items()}))


if __name__ == "__main__":
    main()
