"""Offline DDPG training (``ros2 run cage_reactive_ddpg train`` or ``python -m cage_reactive_ddpg.train``).

  train --preset study --episodes 3000 --out runs/study            # the study's DDPG, shortened
  train --preset fast --out runs/fast --set total_steps=600000      # ours
  train --config config/shipped.yaml --out runs/ship                # what the shipped policy ran

Writes to ``--out``: policy.safetensors + policy.json (the final actor), best.safetensors/.json (best
periodic evaluation), episodes.csv, learning_curve.png, tb/ (TensorBoard), checkpoint.pt +
buffer.npz (``--resume``; missions in flight at the checkpoint restart from a fresh episode).
"""
from __future__ import annotations

import argparse
import csv
import shlex
import sys
import time
from collections import deque
from pathlib import Path

import numpy as np
import torch
from cage_sim.env import CageNavVecEnv
from tqdm import tqdm

from . import config as config_mod
from .agent import DDPGAgent, GaussianNoise, OUNoise
from .buffer import NStepFolder, ReplayBuffer
from .config import TrainConfig
from .evaluate import run_missions, summarize
from .missions import episode_scenarios, parse_mix, sampler, waypoint_fn
from .policy import save_policy
from .study1d import STUDY1D, Study1DVecEnv, evaluate_1d

EVAL_SEED = 987_654      # evaluation episodes during training (disjoint from the reported seeds)


class ActorPolicy:
    """The agent's current actor, without noise, behind the Policy protocol."""

    def __init__(self, agent: DDPGAgent):
        self.agent = agent

    def act(self, obs: np.ndarray) -> np.ndarray:
        return self.agent.act(np.asarray(obs, np.float32))


class Trainer:
    def __init__(self, cfg: TrainConfig, out: Path, command: str = "", progress: bool = True):
        self.cfg, self.out, self.command, self.progress = cfg, out, command, progress
        out.mkdir(parents=True, exist_ok=True)
        torch.manual_seed(cfg.seed)
        torch.set_num_threads(cfg.threads)
        self.rng = np.random.default_rng(cfg.seed)
        self.env_cfg = cfg.env_config()
        self.wp_fn = waypoint_fn(cfg.planner)
        if cfg.scenario == STUDY1D:
            self.envs = Study1DVecEnv(cfg.n_envs, seed=cfg.seed)
            obs_dim = 1
        else:
            self.envs = CageNavVecEnv(cfg.n_envs, sampler(cfg.scenario), self.env_cfg, self.wp_fn, seed=cfg.seed)
            obs_dim = self.env_cfg.layout.size
        self.agent = DDPGAgent(cfg, obs_dim)
        self.buffer = ReplayBuffer(cfg.buffer_size, obs_dim)
        self.folder = NStepFolder(cfg.n_envs, cfg.n_step, cfg.gamma)
        self.noise = OUNoise(cfg.n_envs, 1, cfg.noise_theta, self.rng) if cfg.noise == "ou" \
            else GaussianNoise(cfg.n_envs, 1, self.rng)
        self.step = self.episodes = self.updates = 0
        self.train_seconds = 0.0
        self.best = -np.inf
        self.evals: list[dict] = []
        self.rows: list[dict] = []

    # --- budget ---------------------------------------------------------------------------
    def progress_fraction(self) -> float:
        c = self.cfg
        return self.step / c.total_steps if c.total_steps > 0 else self.episodes / c.episodes

    def prefilling(self) -> bool:
        c = self.cfg
        if c.prefill_steps > 0:
            return self.step < c.prefill_steps
        if c.prefill_steps < 0:
            return self.step < c.buffer_size
        return self.progress_fraction() < c.prefill_fraction

    def noise_std(self) -> float:
        c = self.cfg
        if c.noise_final_std < 0:
            return c.noise_std
        return c.noise_std + (c.noise_final_std - c.noise_std) * min(1.0, self.progress_fraction())

    # --- the loop -------------------------------------------------------------------------
    def run(self) -> dict:
        c = self.cfg
        writer = self._writer()
        csv_file = (self.out / "episodes.csv").open("a", newline="")
        log = csv.DictWriter(csv_file, ["episode", "step", "reward", "length", "outcome", "seconds"])
        if csv_file.tell() == 0:
            log.writeheader()
        obs = self.envs.reset()
        ep_ret, ep_len = np.zeros(c.n_envs), np.zeros(c.n_envs, int)
        recent = deque(maxlen=c.moving_average)
        pending = 0.0
        total = c.total_steps if c.total_steps > 0 else c.episodes
        bar = tqdm(total=total, initial=self.step if c.total_steps > 0 else self.episodes,
                   unit="step" if c.total_steps > 0 else "ep", disable=not self.progress, smoothing=0.05,
                   mininterval=1.0 if sys.stderr.isatty() else 30.0)
        t0, next_eval, next_ckpt = time.time() - self.train_seconds, self._next(c.eval_every), self._next(c.checkpoint_every)
        while self.progress_fraction() < 1.0:
            self.agent.observe(obs)
            if self.prefilling():
                act = self.rng.uniform(-1.0, 1.0, (c.n_envs, 1))
            else:
                act = np.clip(self.agent.act(obs) + self.noise(self.noise_std()), -1.0, 1.0)
            nxt, rew, term, trunc, infos = self.envs.step(act)
            real_next = nxt.copy()
            for i, o in infos.get("final_obs", {}).items():
                real_next[i] = o
            ep_ret += rew
            ep_len += 1
            for i in range(c.n_envs):
                done = bool(term[i] or trunc[i])
                for tr in self.folder.push(i, obs[i], act[i], float(rew[i]), real_next[i], bool(term[i]), done):
                    self.buffer.add(*tr)
                if done:
                    self.episodes += 1
                    row = {"episode": self.episodes, "step": self.step + c.n_envs, "reward": round(float(ep_ret[i]), 3),
                           "length": int(ep_len[i]), "outcome": infos["outcome"][i],
                           "seconds": round(time.time() - t0, 2)}
                    self.rows.append(row)
                    log.writerow(row)
                    recent.append(row)
                    writer and writer.add_scalar("episode/reward", row["reward"], self.episodes)
                    writer and writer.add_scalar("episode/goal", row["outcome"] == "goal", self.episodes)
                    ep_ret[i], ep_len[i] = 0.0, 0
                    self.noise.reset(i)
                    if c.total_steps <= 0:
                        bar.update(1)
            obs = nxt
            self.step += c.n_envs
            if c.total_steps > 0:
                bar.update(c.n_envs)
            if not self.prefilling() and self.buffer.size >= c.batch_size:
                pending += c.updates_per_step * c.n_envs
                while pending >= 1.0:
                    info = self.agent.update(self.buffer.sample(self.rng, c.batch_size))
                    self.updates += 1
                    pending -= 1.0
                if writer and self.updates % 1000 < max(1, c.updates_per_step * c.n_envs):
                    for k, v in info.items():
                        writer.add_scalar(f"train/{k}", v, self.step)
            if recent and self.episodes % 10 == 0:
                bar.set_postfix(reward=f"{np.mean([r['reward'] for r in recent]):.1f}",
                                goal=f"{np.mean([r['outcome'] == 'goal' for r in recent]):.0%}",
                                buf=self.buffer.size, refresh=False)
            if next_eval and self.step >= next_eval:
                self.train_seconds = time.time() - t0
                self._evaluate(writer)
                next_eval += c.eval_every
            if next_ckpt and self.step >= next_ckpt:
                self.train_seconds = time.time() - t0
                self.save_checkpoint()
                next_ckpt += c.checkpoint_every
        bar.close()
        self.train_seconds = time.time() - t0
        csv_file.close()
        final = self._evaluate(writer) if c.eval_episodes > 0 else {"rates": {}}
        self.save_checkpoint()
        self._save("policy", final)
        self.plot_curve()
        if writer:
            writer.close()
        return final

    def _next(self, every: int) -> int:
        return (self.step // every + 1) * every if every > 0 else 0

    def _writer(self):
        if not self.cfg.tensorboard:
            return None
        from torch.utils.tensorboard import SummaryWriter
        return SummaryWriter(str(self.out / "tb"))

    # --- evaluation and saving ------------------------------------------------------------
    def _evaluate(self, writer) -> dict:
        c = self.cfg
        spec = c.eval_scenario or parse_mix(c.scenario)[0][0]
        if spec == STUDY1D:
            s = evaluate_1d(ActorPolicy(self.agent), c.eval_episodes, EVAL_SEED)
        else:
            scs = episode_scenarios(spec, c.eval_episodes, EVAL_SEED, self.wp_fn)
            s = summarize(run_missions(ActorPolicy(self.agent), scs, self.env_cfg))
        s.update(scenario=spec, step=self.step, episodes_trained=self.episodes, seconds=round(self.train_seconds, 1))
        self.evals.append(s)
        if writer:
            for o, r in s["rates"].items():
                writer.add_scalar(f"eval/{o}", r, self.step)
        tqdm.write(f"[eval] step {self.step} ep {self.episodes} t {self.train_seconds:.0f}s {spec}: "
                   + " ".join(f"{o} {100 * r:.1f}%" for o, r in s["rates"].items()))
        score = s["rates"]["goal"] - 2 * s["rates"]["collision"]
        if score >= self.best:      # ties: the later policy has seen more
            self.best = score
            self._save("best", s)
        return s

    def _save(self, name: str, evaluation: dict) -> None:
        c = self.cfg
        meta = {"config": c.to_dict(), "evaluation": evaluation, "evaluations": self.evals,
                "training": {"seconds": round(self.train_seconds, 1), "env_steps": self.step,
                             "episodes": self.episodes, "updates": self.updates,
                             "torch_threads": c.threads, "command": self.command}}
        if c.scenario == STUDY1D:
            meta["observation_layout"] = {"name": STUDY1D, "size": 1}
        save_policy(self.out / f"{name}.safetensors", self.agent.actor, meta,
                    None if c.scenario == STUDY1D else self.env_cfg.layout)

    def save_checkpoint(self) -> None:
        state = {"agent": self.agent.state_dict(), "config": self.cfg.to_dict(),
                 "progress": {"step": self.step, "episodes": self.episodes, "updates": self.updates,
                              "seconds": self.train_seconds, "best": float(self.best)},
                 "rng": self.rng.bit_generator.state,
                 "env_rngs": [r.bit_generator.state for r in self.envs.rngs],
                 "torch_rng": torch.get_rng_state()}
        torch.save(state, self.out / "checkpoint.pt")
        np.savez(self.out / "buffer.npz", **self.buffer.state())

    def load_checkpoint(self, path: Path) -> None:
        s = torch.load(path, weights_only=True)
        self.agent.load_state_dict(s["agent"])
        p = s["progress"]
        self.step, self.episodes, self.updates = p["step"], p["episodes"], p["updates"]
        self.train_seconds, self.best = p["seconds"], p["best"]
        self.rng.bit_generator.state = s["rng"]
        for r, st in zip(self.envs.rngs, s["env_rngs"]):
            r.bit_generator.state = st
        torch.set_rng_state(s["torch_rng"])
        buf = path.parent / "buffer.npz"
        if buf.is_file():
            with np.load(buf) as z:
                self.buffer.load_state(dict(z))

    def plot_curve(self) -> None:
        """Episode reward, its moving average and the overall running average (the study's figures)."""
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        if not self.rows:
            return
        r = np.array([row["reward"] for row in self.rows])
        k = min(self.cfg.moving_average, len(r))
        mov = np.convolve(r, np.ones(k) / k, mode="valid")
        fig, ax = plt.subplots(figsize=(9, 4.5))
        ax.plot(np.arange(1, len(r) + 1), r, lw=0.4, alpha=0.5, label="episode reward")
        ax.plot(np.arange(k, len(r) + 1), mov, lw=1.5, label=f"moving average ({k})")
        ax.plot(np.arange(1, len(r) + 1), np.cumsum(r) / np.arange(1, len(r) + 1), lw=1.5, label="average")
        ax.set_xlabel("episode")
        ax.set_ylabel("reward")
        ax.set_title(f"{self.cfg.scenario}: {len(r)} episodes, {self.step} steps, {self.train_seconds / 60:.1f} min")
        ax.legend()
        fig.tight_layout()
        fig.savefig(self.out / "learning_curve.png", dpi=100)
        plt.close(fig)


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--config", help="YAML file of config keys (may name a preset)")
    ap.add_argument("--preset", help=f"one of {', '.join(config_mod.PRESETS)}")
    ap.add_argument("--scenario", help="name, YAML file or mix a:0.5,b:0.5")
    ap.add_argument("--episodes", type=int, help="episode budget (sets total_steps=0)")
    ap.add_argument("--steps", type=int, help="env-step budget")
    ap.add_argument("--seed", type=int)
    ap.add_argument("--threads", type=int)
    ap.add_argument("--out", default="runs/ddpg")
    ap.add_argument("--resume", help="checkpoint.pt to continue from")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override any config key")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    return ap.parse_args(argv)


def config_from_args(a: argparse.Namespace) -> TrainConfig:
    over: dict = {}
    if a.scenario:
        over["scenario"] = a.scenario
    if a.episodes is not None:
        over.update(episodes=a.episodes, total_steps=0)
    if a.steps is not None:
        over["total_steps"] = a.steps
    if a.seed is not None:
        over["seed"] = a.seed
    if a.threads is not None:
        over["threads"] = a.threads
    cfg = config_mod.build(a.preset, a.config, a.set)
    return config_mod.apply(cfg, over).validate()


def main(argv: list[str] | None = None) -> int:
    a = parse_args(argv)
    command = "train " + " ".join(shlex.quote(x) for x in (sys.argv[1:] if argv is None else argv))
    out = Path(a.out)
    try:   # bad config keys, scenario names or files, checkpoints: one clear line, no traceback
        cfg = config_from_args(a)
        trainer = Trainer(cfg, out, command, progress=not a.quiet)
        if a.resume:
            trainer.load_checkpoint(Path(a.resume))
    except (ValueError, OSError, RuntimeError) as err:
        print(f"train: {err}", file=sys.stderr)
        return 2
    (out / "config.yaml").write_text(__import__("yaml").safe_dump(cfg.to_dict(), sort_keys=False))
    final = trainer.run()
    rates = final.get("rates", {})
    print(f"done: {trainer.step} steps, {trainer.episodes} episodes, {trainer.updates} updates in "
          f"{trainer.train_seconds:.0f} s; eval goal {100 * rates.get('goal', 0):.1f}% "
          f"collision {100 * rates.get('collision', 0):.1f}%; wrote {out}/policy.safetensors")
    return 0


if __name__ == "__main__":
    sys.exit(main())
