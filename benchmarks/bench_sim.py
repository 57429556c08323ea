"""Simulation-core throughput: sonar scans/s (single and batched) and env steps/s.

Scene: the study's cage (30 m net, 20 known 2 x 2 m squares) plus 10 unknown obstacles, 72 beams,
20 m range. Targets (issue 2): >= 50,000 scans/s batched, <= 30 us per single scan, on one core
(numba kernels run on one thread; ``--cpu-time`` divides by this process's CPU time instead of wall
time, for a machine shared with other jobs). Then the sensor profiles (issue 9): batched scans/s of each profile
in the same cage and under a 0.3 m/s current that deforms the net (the polygon wall), a mechanical
head's decision updates/s, and env steps/s of a sea-ready setting (fls + memory + velocity, family
``cage?current=0.5&obstacles=small&schools=3``). Prints tables, then one JSON line of the figures.

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
from cage_sim.mission import EnvConfig
from cage_sim.sonar import PROFILE_NAMES, SonarModel, make_sonar
from cage_sim.world import World


CLOCK = time.perf_counter


def rate(fn, seconds: float, per_call: int = 1) -> float:
    fn()  # warm up (numba compile / caches)
    n, t0 = 0, CLOCK()
    while CLOCK() - t0 < seconds:
        fn()
        n += 1
    return n * per_call / (CLOCK() - t0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--batch", type=int, default=1024)
    ap.add_argument("--cpu-time", action="store_true",
                    help="rates per CPU second of this process (time.process_time) instead of wall time: "
                         "fairer on a machine shared with other jobs (the kernels are single-threaded)")
    args = ap.parse_args()
    if args.cpu_time:
        global CLOCK
        CLOCK = time.process_time
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
    pursuit = ArcController(pursuit=True)      # one more candidate, rolled out afresh at each decision
    pursuit_rate = rate(lambda: pursuit.act(obs), args.seconds)

    figures = {
        "scan_single_us": 1e6 / single, "scans_per_s_single": single,
        "scans_per_s_batched_one_world": batched, "scans_per_s_batched_64_worlds": multi,
        "env_steps_per_s": env_rate, "vec_env_steps_per_s_32": vec_rate,
        "arc_controller_decisions_per_s": ctrl_rate, "arc_controller_pursuit_decisions_per_s": pursuit_rate,
    }
    print(f"{'figure':34s} {'value':>12s}  target")
    targets = {"scan_single_us": "<= 30", "scans_per_s_batched_one_world": ">= 50000"}
    for k, v in figures.items():
        print(f"{k:34s} {v:12.1f}  {targets.get(k, '')}")

    # --- sensor profiles
    deformed = World(world.net_radius, world.known, world.unknown, (0.3, 0.0), world.safety_radius, net_loss=None)
    print(f"\n{'profile':14s} {'beams':>5s} {'scans/s batched':>16s} {'deformed net':>14s}")
    for name in PROFILE_NAMES:
        s = make_sonar(name)
        a = rate(lambda: s.scan_batch([world], poses), args.seconds, args.batch)
        b = rate(lambda: s.scan_batch([deformed], poses), args.seconds, args.batch)
        figures[f"{name}_scans_per_s"], figures[f"{name}_scans_per_s_deformed_net"] = a, b
        print(f"{name:14s} {s.n_beams:5d} {a:16.0f} {b:14.0f}")
    sc_sonar = make_sonar("scanning")
    head = sc_sonar.head()
    head.reset(world, x, y, yaw, 0.0)
    clock = [0.0]

    def head_step():
        clock[0] += 1.0
        head.update(world, x, y, yaw, clock[0])
    figures["scanning_head_decisions_per_s"] = rate(head_step, args.seconds)
    sea = CageNavEnv("cage?current=0.5&obstacles=small&schools=3",
                     EnvConfig(sonar="fls", velocity=True, memory_bins=72))
    sea.reset(seed=0)

    def sea_step():
        _, _, term, trunc, _ = sea.step(zero)
        if term or trunc:
            sea.reset()
    figures["sea_env_steps_per_s_fls_memory"] = rate(sea_step, args.seconds)
    print(f"scanning head decision updates/s (45 beams each) {figures['scanning_head_decisions_per_s']:10.0f}")
    print(f"env steps/s, fls + memory + velocity, 0.5 m/s, 3 schools {figures['sea_env_steps_per_s_fls_memory']:8.0f}")
    print(json.dumps({k: round(v, 2) for k, v in figures.items()}))


if __name__ == "__main__":
    main()
