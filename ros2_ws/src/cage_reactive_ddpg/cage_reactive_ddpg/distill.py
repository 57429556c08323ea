"""Distil the shielded driver into one network: a learned policy that is safe without the shield.

  distill --config config/distill.yaml --out runs/distill              # the default (study) policy
  distill --config config/distill_fls.yaml --out runs/distill_fls      # the fls policy
  distill --config config/distill.yaml --set iterations=2 --set missions=200 --out runs/try

Why: the DDPG policies reach 89-99 % of sea missions alone; behind the safety shield (rollouts with
the drift and the returns' motion, ``cage_sim.shield``) the same policies reach 97-100 % with a
fraction of the collisions. The shield's knowledge is a function of what the vehicle perceives, so
a network that reads the same observation (scan, memory of returns, velocity over ground, waypoint)
can learn most of it. Behaviour cloning of the driver alone is not enough (the student's errors
take it where the driver never flew); DAgger (``dagger.py``) rolls out the student and labels every
state it visits with the shielded driver's action, and the student is trained on all labels so far.

Each iteration k: fly ``missions`` training missions (iteration 0: the teacher alone; then the
student, handing each decision to the teacher with probability ``beta * beta_decay**(k-1)``), label
them, add them to the data set, fit the student (MSE to the labels, overrides weighted by
``override_weight``) and evaluate it alone on held-out missions. The student is an ``Actor`` like
the trainer's (ReLU MLP, tanh), so ``load_policy``, ``evaluate`` and ``policy_node`` run it as they
run any policy; its file records the teacher's sensor profile and observation layout.

Writes to ``--out``: policy.safetensors/.json (the last student), best.safetensors/.json (the best
evaluation: goal rate minus twice the collision rate, as the trainer), iterations.csv,
distill_curve.png, config.yaml. Training missions are drawn from seeds 7,000,000 + 1000 x seed +
iteration (never an evaluation seed); evaluation uses the trainer's evaluation seed (987654).
"""
from __future__ import annotations

import argparse
import csv
import dataclasses
import shlex
import sys
import time
from concurrent.futures import Executor, ProcessPoolExecutor
from dataclasses import dataclass, field
from multiprocessing import get_context
from pathlib import Path
from typing import Any, Callable

import numpy as np
import yaml

from . import config as config_mod
from .dagger import KINDS, OVERRIDE, Labelled, collect, evaluate_student
from .evaluate import wilson
from .missions import PLANNERS
from .policy import load_policy, shipped_path

TRAIN_SEED_BASE = 7_000_000   # training missions: seed 7e6 + 1000 x seed + iteration
EVAL_SEED = 987_654           # the trainer's evaluation seed (train.EVAL_SEED)
CHUNK = 50                    # missions per worker task
INITS = ("teacher", "scratch")
CSV_FIELDS = ["iteration", "beta", "states", "dataset", "overrides", "flown_goal", "flown_collision",
              "fit_loss", "goal", "collision", "wander", "timeout", "seconds"]


@dataclass
class DistillConfig:
    """Every setting of a distillation (YAML file < ``--set`` overrides)."""

    teacher: str = ""                    # policy file flown behind the shield ("" = the shipped default)
    scenario: str = "sea_dr:0.55,sea_hard:0.25,cage:0.1,study2d:0.1"   # training missions (as train)
    planner: str = "rrt"                 # routes, as the graph plans them
    replan: bool = True                  # new plans under way, as policy_node asks for them
    init: str = "teacher"                # "teacher": start as the teacher's network (widened); "scratch"
    hidden: tuple = (256, 256)           # the student's hidden layers (from the teacher: >= its own, same depth)
    imitate: str = "safety,approach,open_water"   # label kinds learnt (dagger.KINDS); others: the teacher's own action
    iterations: int = 6
    missions: int = 1500                 # flown and labelled per iteration
    beta: float = 0.5                    # iteration 1's share of decisions flown by the teacher
    beta_decay: float = 0.5              # ... times this per later iteration
    noise_std: float = 0.1               # on the student's flown actions (not on the labels)
    epochs: int = 6                      # passes over the whole data set per iteration
    batch_size: int = 512
    lr: float = 1e-3                     # Adam, linear to lr_final over the iterations
    lr_final: float = 1e-4
    override_weight: float = 1.0         # loss weight of states where the shield changed the action
    eval_scenario: str = "sea_dr"
    eval_episodes: int = 300
    seed: int = 0
    workers: int = 2                     # processes that fly missions (1 = in this process)
    threads: int = 1                     # torch threads for the fit

    def validate(self) -> "DistillConfig":
        if self.init not in INITS:
            raise ValueError(f"init: expected one of {INITS}, got {self.init!r}")
        if self.planner not in PLANNERS:
            raise ValueError(f"planner: expected one of {PLANNERS}, got {self.planner!r}")
        for name in ("iterations", "missions", "epochs", "batch_size", "workers", "threads"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name}: must be >= 1, got {getattr(self, name)!r}")
        if self.eval_episodes < 0:
            raise ValueError(f"eval_episodes: must be >= 0, got {self.eval_episodes!r}")
        for name in ("beta", "beta_decay"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"{name}: must be in [0, 1], got {getattr(self, name)!r}")
        if self.noise_std < 0 or self.override_weight <= 0 or self.lr <= 0 or self.lr_final <= 0:
            raise ValueError("noise_std must be >= 0; override_weight, lr and lr_final > 0")
        self.hidden = tuple(int(h) for h in self.hidden)
        bad = sorted(set(self.imitated()) - set(KINDS))
        if bad:
            raise ValueError(f"imitate: unknown label kind(s) {bad} (of {', '.join(KINDS)})")
        if not self.hidden or min(self.hidden) < 1:
            raise ValueError(f"hidden: a list of layer sizes >= 1, got {list(self.hidden)!r}")
        return self

    def imitated(self) -> list[str]:
        return [k.strip() for k in self.imitate.split(",") if k.strip()]

    def teacher_path(self) -> str:
        return str(Path(self.teacher) if self.teacher else shipped_path())

    def beta_at(self, iteration: int) -> float:
        """Share of decisions the teacher flies in ``iteration`` (0: all of them)."""
        return 1.0 if iteration == 0 else self.beta * self.beta_decay ** (iteration - 1)

    def lr_at(self, iteration: int) -> float:
        f = iteration / max(1, self.iterations - 1)
        return self.lr + (self.lr_final - self.lr) * f

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["hidden"] = list(self.hidden)
        return d


def build_config(file: str | None = None, overrides: list[str] | dict | None = None) -> DistillConfig:
    cfg = DistillConfig()
    if file:
        config_mod.apply(cfg, config_mod.read_yaml(file))
    return config_mod.apply_overrides(cfg, overrides).validate()


@dataclass
class Dataset:
    """Every labelled state so far (grows by one ``Labelled`` per iteration)."""

    parts: list[Labelled] = field(default_factory=list)

    def add(self, part: Labelled) -> None:
        self.parts.append(part)

    def arrays(self, override_weight: float, imitate: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(obs, target, loss weight) over all parts: the label where its kind is imitated, else
        the teacher's own action (why not every label: the stall watch's hand-overs depend on the
        last 15 decisions, which the observation does not show, so the same observation carries
        both the policy's and the controller's action; learning both learns neither)."""
        all_ = Labelled.join(self.parts)
        learnt = np.isin(all_.kind, [KINDS.index(k) for k in imitate] + [0])
        target = np.where(learnt, all_.label, all_.own).astype(np.float32)
        w = np.where(np.abs(target - all_.own) > OVERRIDE, override_weight, 1.0).astype(np.float32)
        return all_.obs, target, w

    def __len__(self) -> int:
        return sum(len(p.label) for p in self.parts)


class Student:
    """The network being distilled (torch ``Actor``: the trainer's, so every loader runs it)."""

    def __init__(self, obs_dim: int, hidden: tuple, seed: int, threads: int,
                 init: dict[str, np.ndarray] | None = None):
        import torch
        from .networks import Actor
        torch.manual_seed(seed)
        torch.set_num_threads(threads)
        self.actor = Actor(obs_dim, hidden)
        if init is not None:     # the teacher's own weights: the student starts as the raw teacher
            self.actor.load_state_dict({k: torch.from_numpy(np.array(v)) for k, v in init.items()})
        self.opt = torch.optim.Adam(self.actor.parameters(), lr=1e-3)
        self.rng = np.random.default_rng(seed)

    def normalise_with(self, obs: np.ndarray) -> None:
        """Fix the input normalisation to the first data set's statistics (the teacher's states)."""
        import torch
        self.actor.norm.update(torch.from_numpy(obs))

    def state(self) -> dict[str, np.ndarray]:
        return {k: v.detach().numpy().copy() for k, v in self.actor.state_dict().items()}

    def fit(self, obs: np.ndarray, label: np.ndarray, weight: np.ndarray, epochs: int, batch: int,
            lr: float) -> float:
        """Weighted MSE to the labels, ``epochs`` passes; returns the last epoch's mean loss."""
        import torch
        for g in self.opt.param_groups:
            g["lr"] = lr
        x, y, w = torch.from_numpy(obs), torch.from_numpy(label), torch.from_numpy(weight)
        n, loss_sum = len(y), 0.0
        for _ in range(epochs):
            perm = torch.from_numpy(self.rng.permutation(n))
            loss_sum = 0.0
            for lo in range(0, n, batch):
                idx = perm[lo:lo + batch]
                loss = (w[idx] * (self.actor(x[idx])[:, 0] - y[idx]).pow(2)).mean()
                self.opt.zero_grad(set_to_none=True)
                loss.backward()
                self.opt.step()
                loss_sum += float(loss.detach()) * len(idx)
        return loss_sum / n


def widened(state: dict[str, np.ndarray], hidden: tuple, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """An ``Actor`` state dict grown to ``hidden`` units per layer computing the same function.

    Why: the student must hold the teacher's policy and the shield's corrections; starting from the
    teacher keeps what DDPG learnt, and the extra units give room for the rest. New units get
    random input weights (``nn.Linear``'s uniform +-1/sqrt(fan_in)); the old units do not read them
    and the output does not either (zero weights), so the widened network is the teacher exactly
    until training moves those zeros."""
    out = dict(state)
    layers = sorted(int(k.split(".")[1]) for k in state if k.startswith("net.") and k.endswith(".weight"))
    old = [state[f"net.{i}.weight"].shape[0] for i in layers[:-1]]
    if len(old) != len(hidden) or any(h < o for h, o in zip(hidden, old)):
        raise ValueError(f"hidden: {list(hidden)} cannot grow the teacher's {old} (same depth, no layer smaller)")
    sizes = [state[f"net.{layers[0]}.weight"].shape[1], *hidden, state[f"net.{layers[-1]}.weight"].shape[0]]
    for n, i in enumerate(layers):
        w, b = state[f"net.{i}.weight"], state[f"net.{i}.bias"]
        fan_out, fan_in = sizes[n + 1], sizes[n]
        bound = 1.0 / np.sqrt(fan_in)
        nw = np.zeros((fan_out, fan_in), np.float32)
        nw[w.shape[0]:] = rng.uniform(-bound, bound, (fan_out - w.shape[0], fan_in))
        nw[: w.shape[0], : w.shape[1]] = w
        nb = np.zeros(fan_out, np.float32)
        nb[: len(b)] = b
        out[f"net.{i}.weight"], out[f"net.{i}.bias"] = nw, nb
    return out


def _chunks(n: int) -> list[tuple[int, int]]:
    return [(lo, min(CHUNK, n - lo)) for lo in range(0, n, CHUNK)]


class Distiller:
    """One distillation run into ``out`` (see the module doc)."""

    def __init__(self, cfg: DistillConfig, out: Path, command: str = "", progress: bool = True,
                 log: Callable[[str], None] | None = None):
        self.cfg, self.out, self.command, self.progress = cfg, Path(out), command, progress
        self.log = log or (lambda line: print(line, flush=True))
        self.teacher = load_policy(cfg.teacher_path())     # refuses a missing or broken file, naming it
        self.out.mkdir(parents=True, exist_ok=True)
        self.data = Dataset()
        self.student: Student | None = None
        self.rows: list[dict] = []
        self.evals: list[dict] = []
        self.best = -np.inf
        self.seconds = 0.0

    def _map(self, pool: Executor | None, fn, jobs: list[tuple], what: str) -> list:
        from tqdm import tqdm
        bar = tqdm(total=len(jobs), desc=what, unit="task", leave=False, disable=not self.progress,
                   mininterval=1.0 if sys.stderr.isatty() else 30.0)
        out = []
        if pool is None:
            for j in jobs:
                out.append(fn(*j))
                bar.update(1)
        else:
            for r in pool.map(fn, *zip(*jobs)):
                out.append(r)
                bar.update(1)
        bar.close()
        return out

    def run(self) -> dict:
        c = self.cfg
        pool = ProcessPoolExecutor(c.workers, mp_context=get_context("spawn")) if c.workers > 1 else None
        t0 = time.time()
        try:
            for k in range(c.iterations):
                self._iteration(k, pool, t0)
        finally:
            if pool is not None:
                pool.shutdown(cancel_futures=True)
        self._write_csv()
        self.plot()
        return self.evals[-1] if self.evals else {}

    def _iteration(self, k: int, pool: Executor | None, t0: float) -> None:
        c, tp = self.cfg, self.cfg.teacher_path()
        beta = c.beta_at(k)
        student = None if self.student is None else self.student.state()
        seed = TRAIN_SEED_BASE + 1000 * c.seed + k
        jobs = [(tp, student, c.scenario, seed, lo, n, beta, c.noise_std, c.planner, c.replan)
                for lo, n in _chunks(c.missions)]
        part = Labelled.join(self._map(pool, collect, jobs, f"iteration {k}: fly"))
        self.data.add(part)
        if self.student is None:
            self.student = self._new_student(part.obs)
        obs, label, weight = self.data.arrays(c.override_weight, c.imitated())
        loss = self.student.fit(obs, label, weight, c.epochs, c.batch_size, c.lr_at(k))
        ev = self._evaluate(pool, tp)
        self.seconds = time.time() - t0
        flown = sum(part.outcomes.values())
        row = {"iteration": k, "beta": round(beta, 4), "states": len(part.label), "dataset": len(self.data),
               "overrides": round(float(part.overridden.mean()), 4),
               "flown_goal": round(part.outcomes.get("goal", 0) / flown, 4),
               "flown_collision": round(part.outcomes.get("collision", 0) / flown, 4),
               "fit_loss": round(loss, 5), **{o: round(r, 4) for o, r in ev.get("rates", {}).items()},
               "seconds": round(self.seconds, 1)}
        self.rows.append(row)
        self.log(f"[distill] iteration {k}: beta {beta:.3f}, {len(part.label)} states "
                 f"({100 * row['overrides']:.1f} % overridden), flown goal {100 * row['flown_goal']:.1f} % "
                 f"collision {100 * row['flown_collision']:.1f} %; data {len(self.data)}, loss {loss:.4f}; "
                 + (f"student alone on {c.eval_scenario}: " + " ".join(
                     f"{o} {100 * r:.1f}%" for o, r in ev["rates"].items()) if ev else "no evaluation")
                 + f"; {self.seconds:.0f} s")
        self._save("policy", ev)
        if ev:
            score = ev["rates"]["goal"] - 2 * ev["rates"]["collision"]
            if score >= self.best:
                self.best = score
                self._save("best", ev)
        self._write_csv()

    def _new_student(self, obs: np.ndarray) -> Student:
        """From the teacher's weights (``init: teacher``) or a fresh network whose input normalisation
        is fixed to the first data set's statistics (the teacher's states)."""
        c = self.cfg
        if c.init == "teacher":
            from .inference import read_state
            state = widened(read_state(self.teacher.path), c.hidden, np.random.default_rng(c.seed))
            return Student(obs.shape[1], c.hidden, c.seed, c.threads, state)
        s = Student(obs.shape[1], c.hidden, c.seed, c.threads)
        s.normalise_with(obs)
        return s

    def _evaluate(self, pool: Executor | None, tp: str) -> dict:
        c = self.cfg
        if c.eval_episodes == 0:
            return {}
        state = self.student.state()
        jobs = [(tp, state, c.eval_scenario, EVAL_SEED, lo, n, c.planner, c.replan)
                for lo, n in _chunks(c.eval_episodes)]
        counts: dict[str, int] = {}
        for part in self._map(pool, evaluate_student, jobs, "evaluate"):
            for o, v in part.items():
                counts[o] = counts.get(o, 0) + v
        n = sum(counts.values())
        ev = {"episodes": n, "counts": counts, "rates": {o: v / n for o, v in counts.items()},
              "ci95": {o: list(wilson(v, n)) for o, v in counts.items()}, "scenario": c.eval_scenario,
              "seed": EVAL_SEED, "replan": c.replan, "iteration": len(self.evals)}
        self.evals.append(ev)
        return ev

    def _save(self, name: str, evaluation: dict) -> None:
        from .policy import save_policy
        c, tmeta = self.cfg, self.teacher.metadata
        # ``config``: the teacher's training config (sensor, observation, motion: what env_config_for
        # rebuilds), with this run's seed and network; how the weights were made: ``distillation``.
        meta = {"config": {**tmeta.get("config", {}), "seed": c.seed, "actor_hidden": list(self.student.actor.hidden)},
                "evaluation": evaluation, "evaluations": self.evals,
                "training": {"method": "DAgger distillation of the shielded driver", "seconds": round(self.seconds, 1),
                             "env_steps": int(sum(r["states"] for r in self.rows)), "states": len(self.data),
                             "iterations": len(self.rows), "torch_threads": c.threads, "command": self.command},
                "distillation": {"config": c.to_dict(), "iterations": self.rows,
                                 "teacher": {"file": Path(c.teacher_path()).name,
                                             "code_version": tmeta.get("code_version"),
                                             "evaluation": tmeta.get("evaluation")}}}
        save_policy(self.out / f"{name}.safetensors", self.student.actor, meta, self.teacher.layout)

    def _write_csv(self) -> None:
        with (self.out / "iterations.csv").open("w", newline="") as f:
            w = csv.DictWriter(f, CSV_FIELDS, extrasaction="ignore")
            w.writeheader()
            w.writerows(self.rows)

    def plot(self) -> None:
        """Goal and collision rates per iteration: the student alone (held-out) and the missions flown."""
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        if not self.rows:
            return
        it = [r["iteration"] for r in self.rows]
        fig, axes = plt.subplots(1, 2, figsize=(11, 4))
        for ax, key, title in ((axes[0], "goal", "goal %"), (axes[1], "collision", "collision %")):
            if all(key in r for r in self.rows):
                ax.plot(it, [100 * r[key] for r in self.rows], "o-", label=f"student alone ({self.cfg.eval_scenario}, held out)")
            ax.plot(it, [100 * r[f"flown_{key}"] for r in self.rows], "s--", label="missions flown (mixed)")
            ax.set_xlabel("DAgger iteration")
            ax.set_title(title)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
        fig.suptitle(f"distillation of {Path(self.cfg.teacher_path()).name} + shield: {len(self.data)} states, "
                     f"{self.seconds / 60:.1f} min")
        fig.tight_layout()
        fig.savefig(self.out / "distill_curve.png", dpi=100)
        plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--config", help="YAML file of DistillConfig keys")
    ap.add_argument("--teacher", help="policy file flown behind the shield (default: the shipped one)")
    ap.add_argument("--out", default="runs/distill", help="run folder (refused if not empty, unless --force)")
    ap.add_argument("--force", action="store_true", help="write into a non-empty --out")
    ap.add_argument("--seed", type=int)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override any config key")
    ap.add_argument("--quiet", action="store_true", help="no progress bars (the per-iteration lines stay)")
    a = ap.parse_args(argv)
    command = "distill " + " ".join(shlex.quote(x) for x in (sys.argv[1:] if argv is None else argv))
    try:
        over: dict[str, Any] = {}
        if a.teacher:
            over["teacher"] = a.teacher
        if a.seed is not None:
            over["seed"] = a.seed
        cfg = config_mod.apply(build_config(a.config, a.set), over).validate()
        out = Path(a.out)
        if out.is_dir() and any(out.iterdir()) and not a.force:
            raise FileExistsError(f"{out} is not empty: --force writes over its run files")
        run = Distiller(cfg, out, command, progress=not a.quiet)
    except (ValueError, OSError, RuntimeError) as err:      # PolicyLoadError is a RuntimeError
        print(f"distill: {err}", file=sys.stderr)
        return 2
    (out / "config.yaml").write_text(yaml.safe_dump(cfg.to_dict(), sort_keys=False))
    final = run.run()
    rates = final.get("rates", {})
    print(f"done: {len(run.rows)} iterations, {len(run.data)} labelled states in {run.seconds:.0f} s; student alone "
          f"goal {100 * rates.get('goal', 0):.1f}% collision {100 * rates.get('collision', 0):.1f}%; wrote {out}/policy.safetensors")
    return 0


if __name__ == "__main__":
    sys.exit(main())
