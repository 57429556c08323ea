"""Training throughput of our DDPG vs Stable-Baselines3, same env, network sizes and batch, side by side.

Both train on the study's 2D case (``study2d``, study motion), one thread. Measured over the whole run
(env stepping, noise, buffer, updates; after a short random warm-up that both do), alternating the
runs so machine load hits both alike. Two pairs:

  at SB3's settings (SB3's DDPG defaults as the study ran them: 400-300 actor and critic, batch 64,
  one critic, 1 env, 1 update per env step, the study's learning rates, gamma and tau):
    sb3             SB3 DDPG
    ours-1env       our trainer, same settings: the per-update cost compared like for like
  at our settings (preset ``fast``: 128-128, batch 256, twin critics, policy delay 2, target
  smoothing 0.2, 16 envs, 1 update per 4 env steps; 1-step returns for both):
    sb3-td3-fast    SB3 TD3 with those settings (16 envs in a DummyVecEnv, 4 gradient steps per 16)
    ours-fast       our trainer with them (16 envs, one batched sonar call per step)

Prints the ratios (updates/s and env steps/s) at SB3's settings and at ours, then one JSON line.
SB3 is optional (requirements-bench.txt); without it the SB3 rows are skipped.

  python benchmarks/bench_train.py --steps 4000 --repeats 2
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

ARCH = (400, 300)


FAST = {"actor_hidden": [128, 128], "critic_hidden": [128, 128], "batch_size": 256, "twin_critic": True,
        "policy_delay": 2, "target_noise": 0.2, "lr_actor": 3e-4, "lr_critic": 1e-3, "gamma": 0.98,
        "tau": 0.005, "noise": "gaussian", "noise_std": 0.3}


def run_ours(steps: int, warmup: int, n_envs: int, utd: float, seed: int, extra: dict | None = None) -> dict:
    from cage_reactive_ddpg import config as config_mod
    from cage_reactive_ddpg.train import Trainer
    over = {"total_steps": steps, "n_envs": n_envs, "updates_per_step": utd, "prefill_steps": warmup,
            "eval_episodes": 0, "tensorboard": False, "seed": seed, "threads": 1,
            "actor_hidden": list(ARCH), "critic_hidden": list(ARCH), **(extra or {})}
    cfg = config_mod.build("study", overrides=over)
    with tempfile.TemporaryDirectory() as d:
        tr = Trainer(cfg, Path(d), progress=False)
        tr.run()
    return {"env_steps": tr.step, "updates": tr.updates, "seconds": tr.train_seconds}


def run_sb3(steps: int, warmup: int, seed: int, fast: bool = False) -> dict | None:
    try:
        from stable_baselines3 import DDPG, TD3
        from stable_baselines3.common.env_util import make_vec_env
        from stable_baselines3.common.noise import NormalActionNoise, OrnsteinUhlenbeckActionNoise
    except ImportError:
        return None
    from cage_sim.env import CageNavEnv
    from cage_sim.mission import EnvConfig

    def make():
        return CageNavEnv("study2d", EnvConfig(motion="study"))
    if fast:
        f = FAST
        env = make_vec_env(make, n_envs=16, seed=seed)
        model = TD3("MlpPolicy", env, learning_rate=f["lr_critic"], buffer_size=150_000, learning_starts=warmup,
                    batch_size=f["batch_size"], tau=f["tau"], gamma=f["gamma"], train_freq=1, gradient_steps=4,
                    policy_delay=f["policy_delay"], target_policy_noise=f["target_noise"],
                    action_noise=NormalActionNoise(np.zeros(1), f["noise_std"] * np.ones(1)),
                    policy_kwargs={"net_arch": {"pi": f["actor_hidden"], "qf": f["critic_hidden"]}},
                    device="cpu", seed=seed, verbose=0)
    else:
        model = DDPG("MlpPolicy", make(), learning_rate=1e-3, buffer_size=150_000, learning_starts=warmup,
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
            "sb3-td3-fast": lambda s: run_sb3(4 * a.steps, a.warmup, s, fast=True),
            "ours-fast": lambda s: run_ours(4 * a.steps, a.warmup, 16, 0.25, s, FAST)}
    results: dict[str, list[dict]] = {k: [] for k in runs}
    for rep in range(a.repeats):
        for name, fn in runs.items():
            r = fn(rep)
            if r is not None:
                results[name].append(rates(r))
                print(f"[{name} rep {rep}] {results[name][-1]['env_steps_per_s']:.1f} env steps/s, "
                      f"{results[name][-1]['updates_per_s']:.1f} updates/s", file=sys.stderr, flush=True)
    summary = {}
    for name, rs in results.items():
        if rs:
            summary[name] = {k: float(np.median([r[k] for r in rs])) for k in ("env_steps_per_s", "updates_per_s")}
    pairs = {"sb3_settings": ("ours-1env", "sb3"), "our_settings": ("ours-fast", "sb3-td3-fast")}
    print(f"{'run':<16}{'env steps/s':>12}{'updates/s':>11}")
    for name, s in summary.items():
        print(f"{name:<16}{s['env_steps_per_s']:>12.1f}{s['updates_per_s']:>11.1f}")
    out = {"bench": "train_throughput", "threads": a.threads, "steps": a.steps, "repeats": a.repeats,
           "results": summary}
    for label, (ours, theirs) in pairs.items():
        if ours in summary and theirs in summary:
            ru = summary[ours]["updates_per_s"] / summary[theirs]["updates_per_s"]
            re = summary[ours]["env_steps_per_s"] / summary[theirs]["env_steps_per_s"]
            print(f"ratio at {label.replace('_', ' ')}: {ours} / {theirs}: updates/s x{ru:.2f}, env steps/s x{re:.2f}")
            out[f"ratio_{label}"] = {"updates_per_s": ru, "env_steps_per_s": re}
    if "sb3" not in summary:
        print("stable-baselines3 not installed: SB3 rows skipped (pip install -r requirements-bench.txt)")
    print(json.dumps(out))


if __name__ == "__main__":
    main()
