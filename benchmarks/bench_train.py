"""Training throughput of our DDPG vs Stable-Baselines3's DDPG, same env, network sizes and batch.

Both train on the study's 2D case (``study2d``, study motion) with 400-300 actor and critic, batch 64,
the study's learning rates, gamma and tau, one thread. Measured over the whole run (env stepping,
noise, buffer, updates; after a short random warm-up that both do), alternating the runs so machine
load hits both alike. Rows:

  sb3           SB3 DDPG, 1 env, 1 update per env step (train_freq=1, gradient_steps=1)
  ours-1env     our trainer, same settings: the per-update cost compared like for like
  ours-16env    16 envs stepped together (one batched sonar call), still 1 update per env step
  ours-16env-utd0.25   our training default: 16 envs, 1 update per 4 env steps (fewer updates
                       per sample, many more samples per second)

Ends with one JSON line. SB3 is optional (requirements-bench.txt); without it the SB3 row is skipped.

  python benchmarks/bench_train.py --steps 4000 --repeats 1
"""
from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

ARCH = (400, 300)


def run_ours(steps: int, warmup: int, n_envs: int, utd: float, seed: int) -> dict:
    from cage_reactive_ddpg import config as config_mod
    from cage_reactive_ddpg.train import Trainer
    cfg = config_mod.build("study", overrides={
        "total_steps": steps, "n_envs": n_envs, "updates_per_step": utd, "prefill_steps": warmup,
        "eval_episodes": 0, "tensorboard": False, "seed": seed, "threads": 1,
        "actor_hidden": list(ARCH), "critic_hidden": list(ARCH)})
    with tempfile.TemporaryDirectory() as d:
        tr = Trainer(cfg, Path(d), progress=False)
        tr.run()
    return {"env_steps": tr.step, "updates": tr.updates, "seconds": tr.train_seconds}


def run_sb3(steps: int, warmup: int, seed: int) -> dict | None:
    try:
        from stable_baselines3 import DDPG
        from stable_baselines3.common.noise import OrnsteinUhlenbeckActionNoise
    except ImportError:
        return None
    from cage_sim.env import CageNavEnv
    from cage_sim.mission import EnvConfig
    env = CageNavEnv("study2d", EnvConfig(motion="study"))
    model = DDPG("MlpPolicy", env, learning_rate=1e-3, buffer_size=150_000, learning_starts=warmup,
                 batch_size=64, tau=0.001, gamma=0.99, train_freq=1, gradient_steps=1,
                 action_noise=OrnsteinUhlenbeckActionNoise(np.zeros(1), 0.2 * np.ones(1)),
                 policy_kwargs={"net_arch": {"pi": list(ARCH), "qf": list(ARCH)}}, device="cpu", seed=seed,
                 verbose=0)
    t0 = time.perf_counter()
    model.learn(total_timesteps=steps)
    secs = time.perf_counter() - t0
    return {"env_steps": int(model.num_timesteps), "updates": int(model._n_updates), "seconds": secs}


def rates(r: dict) -> dict:
    return {**r, "env_steps_per_s": r["env_steps"] / r["seconds"], "updates_per_s": r["updates"] / r["seconds"]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=4000, help="env steps per run")
    ap.add_argument("--warmup", type=int, default=500, help="random steps before updates start")
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--threads", type=int, default=1)
    a = ap.parse_args()
    torch.set_num_threads(a.threads)
    runs = {"sb3": lambda s: run_sb3(a.steps, a.warmup, s),
            "ours-1env": lambda s: run_ours(a.steps, a.warmup, 1, 1.0, s),
            "ours-16env": lambda s: run_ours(a.steps, a.warmup, 16, 1.0, s),
            "ours-16env-utd0.25": lambda s: run_ours(4 * a.steps, a.warmup, 16, 0.25, s)}
    results: dict[str, list[dict]] = {k: [] for k in runs}
    for rep in range(a.repeats):
        for name, fn in runs.items():
            r = fn(rep)
            if r is not None:
                results[name].append(rates(r))
    summary = {}
    for name, rs in results.items():
        if rs:
            summary[name] = {k: float(np.median([r[k] for r in rs])) for k in ("env_steps_per_s", "updates_per_s")}
    base = summary.get("sb3")
    print(f"{'run':<22}{'env steps/s':>12}{'updates/s':>11}{'x SB3 steps':>13}{'x SB3 upd':>11}")
    for name, s in summary.items():
        rs = (f"{s['env_steps_per_s'] / base['env_steps_per_s']:>13.2f}{s['updates_per_s'] / base['updates_per_s']:>11.2f}"
              if base else f"{'-':>13}{'-':>11}")
        print(f"{name:<22}{s['env_steps_per_s']:>12.1f}{s['updates_per_s']:>11.1f}{rs}")
    if base is None:
        print("stable-baselines3 not installed: SB3 row skipped (pip install -r requirements-bench.txt)")
    out = {"bench": "train_throughput", "arch": list(ARCH), "batch": 64, "threads": a.threads,
           "steps": a.steps, "results": summary}
    if base:
        out["ratio_env_steps"] = {k: v["env_steps_per_s"] / base["env_steps_per_s"] for k, v in summary.items()}
        out["ratio_updates"] = {k: v["updates_per_s"] / base["updates_per_s"] for k, v in summary.items()}
    print(json.dumps(out))


if __name__ == "__main__":
    main()
