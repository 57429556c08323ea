"""Offline DDPG training (``ros2 run cage_reactive_ddpg train`` or ``python -m cage_reactive_ddpg.train``).

  train --preset study --episodes 3000 --out runs/study            # the study's DDPG, shortened
  train --preset fast --out runs/fast --set total_steps=600000      # ours
  train --config config/shipped.yaml --out runs/ship                # what the shipped policy ran
  train --resume runs/ship                                          # continue it (its own config)
  train --resume runs/ship --steps 1200000                          # ... with a larger budget
  train --config config/shipped.yaml --seeds 5 --out runs/ship5     # five seeds (on Ray if installed)
  train --config config/sea_residual_replay_fls.yaml --print-config  # the file with its extends: expanded

Writes to ``--out``: policy.safetensors + policy.json (the final actor), best.safetensors/.json (best
periodic evaluation), episodes.csv and learning_curve.png (the whole run, across resumes), tb/
(TensorBoard, x-axis = env steps), config.yaml, checkpoint.pt + buffer.npz (``--resume``: the
checkpoint carries the config, the counters, every RNG and the evaluations; missions in flight at the
checkpoint restart from a fresh episode). A non-empty ``--out`` is refused unless ``--resume`` or
``--force`` (which deletes the previous run's files first).
"""
from __future__ import annotations

import argparse
import csv
import shlex
import shutil
import sys
import time
from collections import deque
from pathlib import Path
from typing import Any, Callable

import numpy as np
import torch
from cage_sim.controller import ArcController
from cage_sim.driver import FlownLabeller, ObservationLabeller, ShieldFilter, fallback_for, fallback_like
from cage_sim.process_vec_env import ProcessVecEnv
from cage_sim.shield import SafetyShield
from cage_sim.vec_env import CageNavVecEnv, finished
from tqdm import tqdm

from . import config as config_mod
from .agent import DDPGAgent, GaussianNoise, NearReturns, OUNoise
from .buffer import NStepFolder, ReplayBuffer
from .config import TrainConfig
from .evaluate import run_missions, summarize
from .hard_cases import HardCaseReplay
from .missions import episode_scenarios, parse_mix, sampler, waypoint_fn
from .inference import with_base
from .policy import save_policy
from .study1d import STUDY1D, Study1DVecEnv, evaluate_1d

EVAL_SEED = 987_654      # evaluation episodes during training (disjoint from the reported seeds)
CSV_FIELDS = ["episode", "step", "reward", "length", "outcome", "success", "seconds", "demo", "shielded"]
ARTIFACTS = ("policy.safetensors", "policy.json", "best.safetensors", "best.json", "episodes.csv",
             "learning_curve.png", "tb", "checkpoint.pt", "buffer.npz", "config.yaml")
LOG_EVERY = 2000         # env steps between TensorBoard's rollout/time/train scalars


class CheckpointError(ValueError):
    """A checkpoint that cannot be resumed; the message (one line) says why."""


def _one_line(err: BaseException) -> str:
    """``Type: first sentence`` of an error, on one line (torch's messages run to paragraphs)."""
    text = " ".join(str(err).split()).split(". ")[0]
    return f"{type(err).__name__}: {text[:200]}" if text else type(err).__name__


def checkpoint_path(path: str | Path) -> Path:
    """``runs/x`` or ``runs/x/checkpoint.pt`` -> the checkpoint file."""
    p = Path(path)
    return p / "checkpoint.pt" if p.is_dir() else p


def read_checkpoint(path: str | Path) -> dict:
    """Load a checkpoint with ``weights_only=True`` (no pickled code runs); any problem is one
    ``CheckpointError`` line naming the file."""
    p = checkpoint_path(path)
    if not p.exists():
        raise CheckpointError(f"{p}: no such checkpoint (give the run's folder or its checkpoint.pt)")
    try:
        state = torch.load(p, weights_only=True, map_location="cpu")
    except Exception as err:   # torch raises many types here (pickle, zip, OS, Runtime errors)
        raise CheckpointError(f"{p}: not a trainer checkpoint ({_one_line(err)})") from None
    missing = [k for k in ("agent", "config", "progress", "rng") if not isinstance(state, dict) or k not in state]
    if missing:
        raise CheckpointError(f"{p}: not a trainer checkpoint (missing {', '.join(missing)})")
    return state


def _reset(envs) -> tuple[np.ndarray, dict]:
    """First observations and infos from gymnasium's ``(obs, infos)`` or a bare array (Study1DVecEnv)."""
    out = envs.reset()
    return out if isinstance(out, tuple) else (out, {})


def _success(infos: dict, i: int) -> bool:
    fi = infos.get("final_info")
    if isinstance(fi, dict) and "is_success" in fi:
        return bool(fi["is_success"][i])
    return infos["outcome"][i] == "goal"


class ActorPolicy:
    """The agent's current actor, without noise, behind the Policy protocol; a residual actor's
    base action comes from ``residual_base`` (``driver.decide_batch`` gives it the perception)."""

    def __init__(self, agent: DDPGAgent, residual_base: ArcController | None = None):
        self.agent, self.residual_base = agent, residual_base

    def act(self, obs: np.ndarray) -> np.ndarray:
        if self.residual_base is not None:   # the observation alone (perception off)
            return self.act_residual(obs, self.residual_base.act(obs))
        return self.agent.act(np.asarray(obs, np.float32))

    def act_residual(self, obs: np.ndarray, base: np.ndarray) -> np.ndarray:
        return self.agent.act(with_base(obs, base))


class Trainer:
    """One training run into ``out``. ``on_eval(summary)`` is called after every evaluation (the
    sweep reports to Ray Tune from it); ``eval_seed`` fixes the evaluation episodes."""

    def __init__(self, cfg: TrainConfig, out: Path, command: str = "", progress: bool = True,
                 eval_seed: int = EVAL_SEED, on_eval: Callable[[dict], None] | None = None):
        self.cfg, self.out, self.command, self.progress = cfg, Path(out), command, progress
        self.eval_seed, self.on_eval = eval_seed, on_eval
        self.out.mkdir(parents=True, exist_ok=True)
        torch.manual_seed(cfg.seed)
        torch.set_num_threads(cfg.threads)
        self.rng = np.random.default_rng(cfg.seed)
        self.env_cfg = cfg.env_config()
        self.wp_fn = waypoint_fn(cfg.planner)
        self.replay = HardCaseReplay(cfg.replay_fraction, cfg.replay_max_tries, seed=cfg.seed) \
            if cfg.replay_fraction > 0 else None
        # Expert guidance: the classical baseline labels every transition (on the observation alone,
        # or as it is flown: FlownLabeller); a share of the episodes is flown by it (demonstrations).
        # A residual actor reads that label as its base action.
        self.expert = ArcController(self.env_cfg.layout, self.env_cfg.vehicle, pursuit=cfg.expert_pursuit,
                                    handover=cfg.expert_handover, handover_tail=cfg.expert_handover_tail,
                                    remembered=cfg.expert_remembered) if cfg.expert else None
        self.labeller = None if self.expert is None else \
            FlownLabeller(self.expert, self.env_cfg.sonar) if cfg.expert == "flown" else ObservationLabeller(self.expert)
        # The shield in the loop: every action passes the shield the evaluator flies, with the
        # fallback the evaluator gives this policy (a residual actor's base, else the default controller).
        self.shield = ShieldFilter(fallback_like(self.expert if cfg.residual else None, self.env_cfg.layout,
                                                 self.env_cfg.vehicle)) if cfg.shield_in_loop else None
        if cfg.scenario == STUDY1D:
            self.envs = Study1DVecEnv(cfg.n_envs, seed=cfg.seed)
            obs_dim = 1
        elif cfg.env_workers > 1:   # the envs and the expert's rollouts in worker processes (labels come back)
            self.envs = ProcessVecEnv(cfg.n_envs, cfg.env_workers, sampler(cfg.scenario), self.env_cfg, self.wp_fn,
                                      seed=cfg.seed, labeller=self.labeller, replay=self.replay,
                                      action_filter=self.shield)
            obs_dim = int(self.envs.single_observation_space.shape[0])
        else:
            self.envs = CageNavVecEnv(cfg.n_envs, sampler(cfg.scenario), self.env_cfg, self.wp_fn, seed=cfg.seed,
                                      replay=self.replay, action_filter=self.shield)
            obs_dim = int(self.envs.single_observation_space.shape[0])
        obs_dim += int(cfg.residual)     # the base action, appended (with_base)
        near = NearReturns.for_layout(self.env_cfg.layout, cfg.near_bc_range) \
            if cfg.near_bc_weight > 0 and cfg.scenario != STUDY1D else None
        self.agent = DDPGAgent(cfg, obs_dim, near=near)
        self.demo = np.zeros(cfg.n_envs, dtype=bool)
        self.buffer = ReplayBuffer(cfg.buffer_size, obs_dim)
        self.folder = NStepFolder(cfg.n_envs, cfg.n_step, cfg.gamma)
        self.noise = OUNoise(cfg.n_envs, 1, cfg.noise_theta, self.rng) if cfg.noise == "ou" \
            else GaussianNoise(cfg.n_envs, 1, self.rng)
        self.step = self.episodes = self.updates = 0
        self.train_seconds = 0.0
        self.best = -np.inf
        self.evals: list[dict] = []
        self.rows: list[dict] = []
        self.resumed = False

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

    def schedule(self, start: float, final: float) -> float:
        """Linear from ``start`` to ``final`` over the budget; ``final`` < 0 keeps ``start``."""
        if final < 0:
            return start
        return start + (final - start) * min(1.0, self.progress_fraction())

    def noise_std(self) -> float:
        return self.schedule(self.cfg.noise_std, self.cfg.noise_final_std)

    def bc_weight(self) -> float:
        return self.schedule(self.cfg.bc_weight, self.cfg.bc_weight_final) if self.expert is not None else 0.0

    def draw_demo(self, i: int) -> None:
        """Whether env ``i``'s next episode is flown by the expert (only with an expert: the RNG
        stream of plain training is untouched)."""
        if self.expert is not None:
            c = self.cfg
            self.demo[i] = self.rng.random() < self.schedule(c.expert_fraction, c.expert_fraction_final)

    def behaviour(self, obs: np.ndarray, expert: np.ndarray | None) -> np.ndarray:
        """This step's actions: random while prefilling, else the actor plus noise; episodes drawn
        as demonstrations follow the expert plus the same noise."""
        c = self.cfg
        if self.prefilling():
            act = self.rng.uniform(-1.0, 1.0, (c.n_envs, 1))
            std = c.noise_std
        else:
            std = self.noise_std()
            act = self.agent.act(obs) + self.noise(std)
        if expert is not None and self.demo.any():
            noisy = expert + std * self.rng.standard_normal(expert.shape)
            act = np.where(self.demo[:, None], noisy, act)
        return np.clip(act, -1.0, 1.0)

    # --- the loop -------------------------------------------------------------------------
    def run(self) -> dict:
        c = self.cfg
        writer = self._writer()
        # The CSV is rewritten from the rows the checkpoint covers, so a resume neither drops the
        # earlier episodes nor repeats the ones logged after the last checkpoint.
        csv_file = (self.out / "episodes.csv").open("w", newline="")
        log = csv.DictWriter(csv_file, CSV_FIELDS, extrasaction="ignore")
        log.writeheader()
        log.writerows(self.rows)
        obs, infos0 = _reset(self.envs)
        labels, _ = self._labels(obs, infos0)
        ep_ret, ep_len, ep_shielded = np.zeros(c.n_envs), np.zeros(c.n_envs, int), np.zeros(c.n_envs, int)
        recent = deque(self.rows[-c.moving_average:], maxlen=c.moving_average)
        pending = 0.0
        info: dict[str, Any] = {}
        total = c.total_steps if c.total_steps > 0 else c.episodes
        bar = tqdm(total=total, initial=self.step if c.total_steps > 0 else self.episodes,
                   unit="step" if c.total_steps > 0 else "ep", disable=not self.progress, smoothing=0.05,
                   mininterval=1.0 if sys.stderr.isatty() else 30.0)
        t0 = time.time() - self.train_seconds
        next_eval, next_ckpt, next_log = self._next(c.eval_every), self._next(c.checkpoint_every), self._next(LOG_EVERY)
        fps_mark = (self.step, time.time())
        for i in range(c.n_envs):
            self.draw_demo(i)
        # With env worker processes, the updates of a step run while the workers fly it (the buffer
        # then holds every transition up to the step before: one step of 16 later than in one process).
        overlap = isinstance(self.envs, ProcessVecEnv)
        while self.progress_fraction() < 1.0:
            expert = labels                       # the expert's actions on obs (None: no expert)
            pin = with_base(obs, expert if c.residual else None)      # what the actor reads
            self.agent.observe(pin)
            act = self.behaviour(pin, expert)
            if overlap:     # the workers fly this step while the networks learn from the buffer so far
                self.envs.step_async(act)
                pending, info = self._learn(pending, info)
                nxt, rew, term, trunc, infos = self.envs.step_wait()
            else:
                nxt, rew, term, trunc, infos = self.envs.step(act)
            labels, final_labels = self._labels(nxt, infos)
            real_next = nxt.copy()
            for i, o in finished(infos):
                real_next[i] = o
            next_in = real_next
            if c.residual:     # the base action of each next state: of the last one where an episode ended
                next_in = with_base(real_next, np.where(np.isfinite(final_labels), final_labels, labels))
            if "shielded" in infos:    # the shield replaced these envs' actions (shield_in_loop)
                rew = rew - c.shield_penalty * infos["shielded"]
                ep_shielded += infos["shielded"].astype(int)
            ep_ret += rew
            ep_len += 1
            for i in range(c.n_envs):
                done = bool(term[i] or trunc[i])
                for tr in self.folder.push(i, pin[i], act[i], float(rew[i]), next_in[i], bool(term[i]), done,
                                           None if expert is None else expert[i]):
                    self.buffer.add(*tr)
                if done:
                    self.episodes += 1
                    row = {"episode": self.episodes, "step": self.step + c.n_envs, "reward": round(float(ep_ret[i]), 3),
                           "length": int(ep_len[i]), "outcome": infos["outcome"][i],
                           "success": int(_success(infos, i)), "seconds": round(time.time() - t0, 2),
                           "demo": int(self.demo[i]), "shielded": int(ep_shielded[i])}
                    self.rows.append(row)
                    log.writerow(row)
                    recent.append(row)
                    if writer:
                        writer.add_scalar("episode/reward", row["reward"], row["step"])
                        writer.add_scalar("episode/length", row["length"], row["step"])
                        writer.add_scalar("episode/success", row["success"], row["step"])
                    ep_ret[i], ep_len[i], ep_shielded[i] = 0.0, 0, 0
                    self.noise.reset(i)
                    self.draw_demo(i)
                    if c.total_steps <= 0:
                        bar.update(1)
            obs = nxt
            self.step += c.n_envs
            if c.total_steps > 0:
                bar.update(c.n_envs)
            if not overlap:
                pending, info = self._learn(pending, info)
            if self.step >= next_log:
                now = time.time()
                fps = (self.step - fps_mark[0]) / max(now - fps_mark[1], 1e-9)
                fps_mark, next_log = (self.step, now), next_log + LOG_EVERY
                if writer:
                    self._log_rollout(writer, recent, info, fps)
            if recent and self.episodes % 10 == 0:
                bar.set_postfix(reward=f"{np.mean([r['reward'] for r in recent]):.1f}",
                                goal=f"{np.mean([r['success'] for r in recent]):.0%}",
                                buf=self.buffer.size, refresh=False)
            if next_eval and self.step >= next_eval:
                self.train_seconds = time.time() - t0
                self._evaluate(writer)
                next_eval += c.eval_every
            if next_ckpt and self.step >= next_ckpt:
                self.train_seconds = time.time() - t0
                csv_file.flush()
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
            self._log_hparams(writer, final)
            writer.close()
        self.envs.close()       # env worker processes end here
        return final

    def _labels(self, obs: np.ndarray, infos: dict) -> tuple[np.ndarray | None, np.ndarray | None]:
        """The expert's actions on ``obs`` and on the last observation of each episode that ended
        (NaN elsewhere): from the env workers, or from the labeller here (None, None: no expert)."""
        if self.labeller is None:
            return None, None
        if "labels" in infos:
            return infos["labels"], infos["final_labels"]
        return self.labeller(obs, getattr(self.envs, "missions", []), finished(infos))

    def _learn(self, pending: float, info: dict) -> tuple[float, dict]:
        """The gradient updates this env step earns (``updates_per_step`` per env step, once the
        prefill is over and the buffer holds a batch); ``pending`` carries the fraction left over."""
        c = self.cfg
        if not self.prefilling() and self.buffer.size >= c.batch_size:
            pending += c.updates_per_step * c.n_envs
            while pending >= 1.0:
                info = self.agent.update(self.buffer.sample(self.rng, c.batch_size), self.bc_weight())
                self.updates += 1
                pending -= 1.0
        return pending, info

    def _next(self, every: int) -> int:
        return (self.step // every + 1) * every if every > 0 else 0

    def _writer(self):
        if not self.cfg.tensorboard:
            return None
        from torch.utils.tensorboard import SummaryWriter
        # After a resume, events past the checkpoint's step (written before a crash) are purged.
        return SummaryWriter(str(self.out / "tb"), purge_step=self.step + 1 if self.resumed else None)

    def _log_rollout(self, writer, recent: deque, info: dict, fps: float) -> None:
        s = self.step
        writer.add_scalar("time/fps", fps, s)
        writer.add_scalar("time/updates", self.updates, s)
        writer.add_scalar("train/noise_std", 0.0 if self.prefilling() else self.noise_std(), s)
        writer.add_scalar("train/buffer_size", self.buffer.size, s)
        if self.expert is not None:
            writer.add_scalar("train/bc_weight", self.bc_weight(), s)
        if self.replay is not None:
            for k, v in self.replay.stats().items():
                writer.add_scalar(f"replay/{k}", v, s)
        for k, v in info.items():
            writer.add_scalar(f"train/{k}", float(v), s)
        if recent:
            writer.add_scalar("rollout/success_rate", float(np.mean([r["success"] for r in recent])), s)
            writer.add_scalar("rollout/ep_rew_mean", float(np.mean([r["reward"] for r in recent])), s)
            writer.add_scalar("rollout/ep_len_mean", float(np.mean([r["length"] for r in recent])), s)
            if self.shield is not None:     # the share of decisions the shield replaced
                writer.add_scalar("rollout/shielded_fraction", sum(r["shielded"] for r in recent)
                                  / max(1, sum(r["length"] for r in recent)), s)

    def _log_hparams(self, writer, final: dict) -> None:
        hp = {k: (v if isinstance(v, (int, float, str, bool)) else str(v)) for k, v in self.cfg.to_dict().items()}
        metrics = {f"hparam/{o}": float(r) for o, r in final.get("rates", {}).items()}
        writer.add_hparams(hp, metrics or {"hparam/episodes": float(self.episodes)}, run_name=".",
                           global_step=self.step)

    # --- evaluation and saving ------------------------------------------------------------
    def _evaluate(self, writer) -> dict:
        c = self.cfg
        spec = c.eval_scenario or parse_mix(c.scenario)[0][0]
        if spec == STUDY1D:
            s = evaluate_1d(self.actor_policy(), c.eval_episodes, self.eval_seed)
        else:
            scs = episode_scenarios(spec, c.eval_episodes, self.eval_seed, self.wp_fn)
            s = summarize(run_missions(self.eval_driver(), scs, self.env_cfg))
        s.update(driver="shield" if c.shield_in_loop else "raw", scenario=spec, step=self.step,
                 episodes_trained=self.episodes, seconds=round(self.train_seconds, 1))
        self.evals.append(s)
        if writer:
            for o, r in s["rates"].items():
                writer.add_scalar(f"eval/{o}", r, self.step)
        tqdm.write(f"[eval] step {self.step} ep {self.episodes} t {self.train_seconds:.0f}s {spec}"
                   f"{' behind the shield' if c.shield_in_loop else ''}: "
                   + " ".join(f"{o} {100 * r:.1f}%" for o, r in s["rates"].items()))
        score = s["rates"]["goal"] - 2 * s["rates"]["collision"]
        if score >= self.best:      # ties: the later policy has seen more
            self.best = score
            self._save("best", s)
        if self.on_eval is not None:
            self.on_eval(s)
        return s

    def actor_policy(self) -> ActorPolicy:
        return ActorPolicy(self.agent, self.expert if self.cfg.residual else None)

    def eval_driver(self):
        """What the periodic evaluations fly: the actor, behind the shield when it trains behind one."""
        pol = self.actor_policy()
        if self.shield is None:
            return pol
        return SafetyShield(pol, fallback_for(pol, self.env_cfg.layout, self.env_cfg.vehicle))

    def _save(self, name: str, evaluation: dict) -> None:
        c = self.cfg
        meta = {"config": c.to_dict(), "evaluation": evaluation, "evaluations": self.evals,
                "training": {"seconds": round(self.train_seconds, 1), "env_steps": self.step,
                             "episodes": self.episodes, "updates": self.updates,
                             "torch_threads": c.threads, "command": self.command,
                             **({"hard_case_replay": self.replay.stats()} if self.replay is not None else {})}}
        if c.scenario == STUDY1D:
            meta["observation_layout"] = {"name": STUDY1D, "size": 1}
        else:   # every setting of the sonar it learnt on: evaluate and policy_node rebuild this one
            meta["sonar"] = self.env_cfg.sonar.to_dict()
        save_policy(self.out / f"{name}.safetensors", self.agent.actor, meta,
                    None if c.scenario == STUDY1D else self.env_cfg.layout, base=self.expert)

    def save_checkpoint(self) -> None:
        state = {"agent": self.agent.state_dict(), "config": self.cfg.to_dict(),
                 "progress": {"step": self.step, "episodes": self.episodes, "updates": self.updates,
                              "seconds": self.train_seconds, "best": float(self.best)},
                 "evals": _plain(self.evals),
                 "rng": self.rng.bit_generator.state,
                 "env_rngs": self.envs.rng_states(),
                 "torch_rng": torch.get_rng_state()}
        tmp = self.out / "checkpoint.pt.tmp"
        torch.save(state, tmp)
        tmp.replace(self.out / "checkpoint.pt")      # never a half-written checkpoint
        np.savez(self.out / "buffer.npz", **self.buffer.state())

    def load_checkpoint(self, path: str | Path, state: dict | None = None) -> None:
        """Restore a checkpoint (read with ``read_checkpoint`` unless ``state`` is given) and the
        episode rows of its run's episodes.csv up to the checkpoint. Problems: ``CheckpointError``."""
        p = checkpoint_path(path)
        s = state if state is not None else read_checkpoint(p)
        try:
            self.agent.load_state_dict(s["agent"])
            pr = s["progress"]
            self.step, self.episodes, self.updates = int(pr["step"]), int(pr["episodes"]), int(pr["updates"])
            self.train_seconds, self.best = float(pr["seconds"]), float(pr["best"])
            self.rng.bit_generator.state = s["rng"]
            self.envs.set_rng_states(s["env_rngs"])
            torch.set_rng_state(s["torch_rng"])
        except (KeyError, RuntimeError, ValueError, TypeError) as err:
            raise CheckpointError(f"{p}: does not fit this trainer and config ({_one_line(err)})") from None
        self.evals = list(s.get("evals", []))
        buf = p.parent / "buffer.npz"
        if buf.is_file():
            try:
                with np.load(buf) as z:
                    self.buffer.load_state(dict(z))
            except Exception as err:   # zip/pickle/shape errors of a damaged file
                raise CheckpointError(f"{buf}: unreadable replay buffer ({_one_line(err)})") from None
        self.rows = read_rows(p.parent / "episodes.csv", self.episodes)
        self.resumed = True

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


def _plain(x: Any) -> Any:
    """Evaluations as plain Python (what ``torch.load(weights_only=True)`` accepts)."""
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, (np.floating, np.integer, np.bool_)):
        return x.item()
    return x


def read_rows(path: Path, up_to: int) -> list[dict]:
    """The episode rows of a run's CSV up to episode ``up_to`` (a missing file: none)."""
    if not path.is_file():
        return []
    rows = []
    with path.open(newline="") as f:
        for r in csv.DictReader(f):
            try:
                ep = int(r["episode"])
                if ep > up_to:
                    break
                rows.append({"episode": ep, "step": int(r["step"]), "reward": float(r["reward"]),
                             "length": int(r["length"]), "outcome": r["outcome"],
                             "success": int(r.get("success") or r["outcome"] == "goal"),
                             "seconds": float(r["seconds"]), "demo": int(r.get("demo") or 0),
                             "shielded": int(r.get("shielded") or 0)})
            except (KeyError, TypeError, ValueError) as err:
                raise CheckpointError(f"{path}: unreadable episode row ({_one_line(err)})") from None
    return rows


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--config", help="YAML file of config keys (may name a preset)")
    ap.add_argument("--preset", help=f"one of {', '.join(config_mod.PRESETS)}")
    ap.add_argument("--scenario", help="name, YAML file or mix a:0.5,b:0.5")
    ap.add_argument("--episodes", type=int, help="episode budget (sets total_steps=0)")
    ap.add_argument("--steps", type=int, help="env-step budget")
    ap.add_argument("--seed", type=int)
    ap.add_argument("--threads", type=int)
    ap.add_argument("--out", help="run folder (default runs/ddpg; with --resume: the checkpoint's folder)")
    ap.add_argument("--resume", help="run folder or checkpoint.pt to continue (its own config; flags override)")
    ap.add_argument("--force", action="store_true", help="start over in a non-empty --out (deletes its run files)")
    ap.add_argument("--seeds", type=int, default=0,
                    help="train N seeds (seed, seed+1, ...) into OUT/seed_K and aggregate them (Ray when installed)")
    ap.add_argument("--no-ray", action="store_true", help="with --seeds: one after another even if Ray is installed")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override any config key")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    ap.add_argument("--print-config", action="store_true",
                    help="print the expanded config (extends:, preset, --set and flags applied) and exit")
    return ap.parse_args(argv)


def config_from_args(a: argparse.Namespace, base: TrainConfig | None = None) -> TrainConfig:
    """Defaults (or a checkpoint's config) < preset < --config < --set < the named flags."""
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
    cfg = config_mod.build(a.preset, a.config, a.set, base=base)
    return config_mod.apply(cfg, over).validate()


def prepare_out(out: Path, force: bool) -> None:
    """Refuse a non-empty run folder (a fresh run would mix its files with another's) unless
    ``force``, which deletes the trainer's own files there (and nothing else)."""
    if not out.is_dir() or not any(out.iterdir()):
        return
    if not force:
        raise FileExistsError(f"{out} is not empty: --resume {out} continues that run, --force starts over in it")
    for name in ARTIFACTS:
        p = out / name
        if p.is_dir():
            shutil.rmtree(p)
        elif p.exists():
            p.unlink()


def _print_config(cfg: TrainConfig) -> int:
    print(config_mod.to_yaml(cfg), end="")
    return 0


def main(argv: list[str] | None = None) -> int:
    a = parse_args(argv)
    command = "train " + " ".join(shlex.quote(x) for x in (sys.argv[1:] if argv is None else argv))
    try:   # bad config keys, scenario names or files, checkpoints, a used --out: one clear line
        if a.print_config and not a.resume:
            return _print_config(config_from_args(a))
        if a.seeds:
            if a.resume:
                raise ValueError("--seeds and --resume: resume each seed's folder on its own")
            from .seeds import train_seeds
            out = Path(a.out or "runs/ddpg")
            prepare_out(out, a.force)
            return train_seeds(config_from_args(a), out, a.seeds, command, use_ray=not a.no_ray,
                               progress=not a.quiet)
        state = None
        if a.resume:
            ck = checkpoint_path(a.resume)
            state = read_checkpoint(ck)
            try:
                base = config_mod.from_dict(state["config"])
            except (ValueError, TypeError) as err:
                raise CheckpointError(f"{ck}: its config does not fit this build ({_one_line(err)})") from None
            cfg = config_from_args(a, base)
            if a.print_config:
                return _print_config(cfg)
            out = Path(a.out) if a.out else ck.parent
            if out.resolve() != ck.parent.resolve():
                prepare_out(out, a.force)
        else:
            cfg = config_from_args(a)
            out = Path(a.out or "runs/ddpg")
            prepare_out(out, a.force)
        trainer = Trainer(cfg, out, command, progress=not a.quiet)
        if a.resume:
            trainer.load_checkpoint(ck, state)
    except (ValueError, OSError, RuntimeError) as err:
        print(f"train: {err}", file=sys.stderr)
        return 2
    (out / "config.yaml").write_text(config_mod.to_yaml(cfg))
    final = trainer.run()
    rates = final.get("rates", {})
    print(f"done: {trainer.step} steps, {trainer.episodes} episodes, {trainer.updates} updates in "
          f"{trainer.train_seconds:.0f} s; eval goal {100 * rates.get('goal', 0):.1f}% "
          f"collision {100 * rates.get('collision', 0):.1f}%; wrote {out}/policy.safetensors")
    return 0


if __name__ == "__main__":
    sys.exit(main())
