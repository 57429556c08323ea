"""Hyperparameter sweeps on Ray Tune, with Optuna (TPE) as the search algorithm and ASHA early stopping.

  sweep --config config/sweep.yaml                       # local Ray (all CPUs of this machine)
  sweep --config config/sweep.yaml --address auto        # a running cluster (see the package README)
  sweep --config config/sweep.yaml                       # again: resumes the unfinished sweep

Each trial trains the base config with the sampled values (one CPU, one torch thread) and evaluates it
``reports`` times on held-out missions (``eval_seed``, never a training episode); each evaluation is
reported to Tune (objective: the goal rate) with a checkpoint, so ASHA stops poor trials at its rungs
and an interrupted sweep resumes (``Tuner.restore``: finished trials kept, unfinished ones continue
from their last checkpoint). Writes to ``OUT/<name>/`` (Tune's own files) and to ``OUT/``:
``<name>_trials.csv`` (one row per trial: values, objective, evaluations done, stopped early),
``<name>_best.yaml`` (the best trial's full trainer config: ``train --config`` it), ``<name>.png``
(objective vs trial with the running best; Optuna's parameter importance).

``--reference`` trains the base config itself (none of the space's values changed) under the same
protocol (budget, evaluations, held-out missions), here, without Ray, and writes
``<name>_reference.json``: the figure the best trial must beat. The results table, the printed
line and the PNG (a dashed line) include it when it is there.

The sweep file (every key checked):

  name: fast_lr             # experiment name (folder under --out)
  base: {preset: fast, total_steps: 200000, ...}   # trainer config: preset and/or any config keys
  space:                    # config keys -> one distribution each
    lr_actor: {loguniform: [1.0e-4, 1.0e-3]}
    tau: {uniform: [0.002, 0.02]}
    batch_size: {choice: [128, 256, 512]}
    actor_hidden: {choice: [[64, 64], [128, 128]]}
  trials: 32                # number of trials
  reports: 4                # evaluations per trial (ASHA's rungs count in these)
  grace: 1                  # ASHA: evaluations before a trial may be stopped
  reduction_factor: 2       # ASHA
  eval_episodes: 100        # held-out missions per evaluation
  eval_seed: 424242         # their seed (disjoint from training and from the trainer's own)
  concurrent: 2             # trials at once (default: the CPUs Ray sees)
  seed: 0                   # Optuna's sampler seed
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import os
import shutil
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from . import config as config_mod

DISTRIBUTIONS = ("uniform", "loguniform", "choice", "randint")
SPEC_KEYS = {"name", "base", "space", "trials", "reports", "grace", "reduction_factor", "eval_episodes",
             "eval_seed", "concurrent", "seed"}
INSTALL_HINT = "Ray is not installed: bash scripts/setup.sh --with-ray (pip install -r requirements-ray.txt)"


@dataclass
class SweepSpec:
    name: str
    base: dict
    space: dict[str, dict[str, Any]]
    trials: int = 32
    reports: int = 4
    grace: int = 1
    reduction_factor: int = 2
    eval_episodes: int = 100
    eval_seed: int = 424_242
    concurrent: int = 0
    seed: int = 0
    base_config: dict = field(default_factory=dict)


def load_spec(path: str | Path) -> SweepSpec:
    """Read and check a sweep file; any problem is a ``ValueError`` naming the key."""
    p = Path(path)
    try:
        data = yaml.safe_load(p.read_text())
    except yaml.YAMLError as err:
        raise ValueError(f"{p}: not valid YAML ({' '.join(str(err).split())})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{p}: expected a mapping with base, space, trials, ...")
    unknown = set(data) - SPEC_KEYS
    if unknown:
        raise ValueError(f"{sorted(unknown)[0]}: unknown sweep key (known: {', '.join(sorted(SPEC_KEYS))})")
    base = dict(data.get("base") or {})
    preset = base.pop("preset", None)
    cfg = config_mod.build(preset, overrides=base)
    space = data.get("space")
    if not isinstance(space, dict) or not space:
        raise ValueError("space: expected a mapping of config keys to distributions")
    names = set(cfg.to_dict())
    for key, dist in space.items():
        if key not in names and not key.startswith("reward."):
            raise ValueError(f"space.{key}: unknown config key")
        if not isinstance(dist, dict) or len(dist) != 1 or next(iter(dist)) not in DISTRIBUTIONS:
            raise ValueError(f"space.{key}: expected one of {{{', '.join(DISTRIBUTIONS)}: [...]}}")
        kind, args = next(iter(dist.items()))
        if not isinstance(args, list) or (kind != "choice" and len(args) != 2) or not args:
            raise ValueError(f"space.{key}.{kind}: expected [low, high]" if kind != "choice"
                             else f"space.{key}.choice: expected a non-empty list")
    spec = SweepSpec(name=str(data.get("name") or p.stem), base=dict(data.get("base") or {}), space=space,
                     base_config=cfg.to_dict())
    for k in ("trials", "reports", "grace", "reduction_factor", "eval_episodes", "eval_seed", "concurrent", "seed"):
        if k in data:
            v = data[k]
            if not isinstance(v, int) or isinstance(v, bool) or (v < 1 and k not in ("concurrent", "seed", "eval_seed")):
                raise ValueError(f"{k}: expected a positive integer, got {v!r}")
            setattr(spec, k, v)
    if cfg.total_steps <= 0:
        raise ValueError("base.total_steps: sweeps budget trials in env steps (set total_steps)")
    return spec


def _encode(v: Any) -> Any:
    """Optuna's categorical choices must be scalars: lists travel as JSON strings."""
    return json.dumps(v) if isinstance(v, (list, tuple, dict)) else v


def _decode(v: Any) -> Any:
    if isinstance(v, str) and v[:1] in "[{":
        return json.loads(v)
    return v


def tune_space(spec: SweepSpec) -> dict:
    from ray import tune
    out = {}
    for key, dist in spec.space.items():
        kind, args = next(iter(dist.items()))
        if kind == "uniform":
            out[key] = tune.uniform(float(args[0]), float(args[1]))
        elif kind == "loguniform":
            out[key] = tune.loguniform(float(args[0]), float(args[1]))
        elif kind == "randint":
            out[key] = tune.randint(int(args[0]), int(args[1]) + 1)
        else:
            out[key] = tune.choice([_encode(a) for a in args])
    return out


def trial_config(base_config: dict, params: dict, spec: SweepSpec) -> config_mod.TrainConfig:
    """The trainer config of one trial: base + sampled values; one thread, ``reports`` evaluations."""
    cfg = config_mod.apply(config_mod.from_dict(base_config), {k: _decode(v) for k, v in params.items()})
    every = max(cfg.n_envs, cfg.total_steps // spec.reports)
    return config_mod.apply(cfg, {"threads": 1, "eval_every": every, "checkpoint_every": 0,
                                  "eval_episodes": spec.eval_episodes, "tensorboard": False}).validate()


def run_trial(params: dict, base_config: dict, spec: SweepSpec) -> None:
    """Ray Tune function trainable: train, reporting each held-out evaluation with a checkpoint."""
    from ray import tune

    from .train import Trainer
    cfg = trial_config(base_config, params, spec)
    out = Path(tune.get_context().get_trial_dir()) / "run"
    reported = {"step": -1}

    def report(s: dict) -> None:
        if tr.step == reported["step"]:     # the final evaluation repeats the last periodic one
            return
        reported["step"] = tr.step
        tr.save_checkpoint()
        metrics = {"goal": s["rates"]["goal"], "collision": s["rates"]["collision"],
                   "env_steps": tr.step, "train_seconds": tr.train_seconds}
        with tempfile.TemporaryDirectory() as d:
            for f in ("checkpoint.pt", "buffer.npz", "episodes.csv"):
                if (out / f).is_file():
                    shutil.copy2(out / f, Path(d) / f)
            tune.report(metrics, checkpoint=tune.Checkpoint.from_directory(d))

    tr = Trainer(cfg, out, command=f"sweep {spec.name}", progress=False, eval_seed=spec.eval_seed, on_eval=report)
    ck = tune.get_checkpoint()
    if ck is not None:
        with ck.as_directory() as d:
            for f in ("buffer.npz", "episodes.csv"):
                if (Path(d) / f).is_file():
                    shutil.copy2(Path(d) / f, out / f)
            tr.load_checkpoint(Path(d) / "checkpoint.pt")
            reported["step"] = tr.step
    tr.run()


def saved_results(spec: SweepSpec, out: Path):
    """The ResultGrid of the experiment under ``out`` as it stands (finished and stopped trials; the
    ones still running or pending report what they reached), without running anything."""
    from ray import tune
    exp = out.resolve() / spec.name
    if not tune.Tuner.can_restore(str(exp)):
        raise RuntimeError(f"sweep: no experiment to report in {exp}")
    return tune.Tuner.restore(str(exp), tune.with_parameters(run_trial, base_config=spec.base_config,
                                                              spec=spec)).get_results()


def run_sweep(spec: SweepSpec, out: Path, address: str | None = None, progress: bool = True):
    """Run (or resume) the sweep; return Tune's ResultGrid."""
    os.environ.setdefault("TUNE_WARN_EXCESSIVE_EXPERIMENT_CHECKPOINT_SYNC_THRESHOLD_S", "0")
    import ray
    from ray import tune
    from ray.tune.schedulers import ASHAScheduler
    from ray.tune.search import ConcurrencyLimiter
    from ray.tune.search.optuna import OptunaSearch
    out = out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    if not ray.is_initialized():
        ray.init(address=address, include_dashboard=False, log_to_driver=False, configure_logging=False)
    trainable = tune.with_resources(tune.with_parameters(run_trial, base_config=spec.base_config, spec=spec),
                                    {"cpu": 1})
    exp = out / spec.name
    if tune.Tuner.can_restore(str(exp)):
        print(f"sweep: resuming {exp}", file=sys.stderr)
        tuner = tune.Tuner.restore(str(exp), trainable, resume_unfinished=True, resume_errored=True)
    else:
        concurrent = spec.concurrent or max(1, int(ray.cluster_resources().get("CPU", 1)))
        search = ConcurrencyLimiter(OptunaSearch(seed=spec.seed), max_concurrent=concurrent)
        asha = ASHAScheduler(time_attr="training_iteration", max_t=spec.reports, grace_period=spec.grace,
                             reduction_factor=spec.reduction_factor)
        tuner = tune.Tuner(
            trainable, param_space=tune_space(spec),
            tune_config=tune.TuneConfig(metric="goal", mode="max", search_alg=search, scheduler=asha,
                                        num_samples=spec.trials),
            run_config=tune.RunConfig(name=spec.name, storage_path=str(out), verbose=1 if progress else 0,
                                      checkpoint_config=tune.CheckpointConfig(num_to_keep=1)))
    return tuner.fit()


def run_reference(spec: SweepSpec, out: Path, progress: bool = True) -> dict:
    """Train the base config under the trial protocol and write ``<name>_reference.json``."""
    from .train import Trainer
    cfg = trial_config(spec.base_config, {}, spec)
    run = out / f"{spec.name}_reference"
    if run.exists():
        shutil.rmtree(run)
    evals: list[dict] = []

    def record(s: dict) -> None:
        if not evals or evals[-1]["env_steps"] != tr.step:    # the final evaluation repeats the last periodic one
            evals.append({"goal": s["rates"]["goal"], "collision": s["rates"]["collision"], "env_steps": tr.step})

    tr = Trainer(cfg, run, command=f"sweep {spec.name} --reference", progress=progress, eval_seed=spec.eval_seed,
                 on_eval=record)
    tr.run()
    ref = {**evals[-1], **{k: _decode(_encode(getattr(cfg, k))) for k in spec.space},
           "evaluations": evals, "train_seconds": tr.train_seconds}
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{spec.name}_reference.json").write_text(json.dumps(ref, indent=1))
    return ref


def load_reference(spec: SweepSpec, out: Path) -> dict | None:
    f = out / f"{spec.name}_reference.json"
    return json.loads(f.read_text()) if f.is_file() else None


def _trial_number(result, default: int) -> int:
    """Tune names trial folders ``run_trial_<id>_<n>_<params>``: n (1-based) is the proposal order."""
    try:
        return int(Path(result.path).name.split("_")[3]) - 1
    except (AttributeError, IndexError, TypeError, ValueError):
        return default


def write_results(spec: SweepSpec, grid, out: Path) -> dict:
    """Trials CSV, best trainer YAML and PNG; returns the best trial's row."""
    import csv
    rows = []
    for i, r in enumerate(grid):
        if r.metrics is None or "goal" not in (r.metrics or {}):
            continue
        cfg = r.config or {}
        rows.append({"trial": _trial_number(r, i), "trial_id": r.metrics.get("trial_id", ""),
                     **{k: _decode(cfg.get(k)) for k in spec.space},
                     "goal": r.metrics["goal"], "collision": r.metrics["collision"],
                     "evaluations": r.metrics.get("training_iteration", 0),
                     "stopped_early": r.metrics.get("training_iteration", 0) < spec.reports,
                     "env_steps": r.metrics.get("env_steps", 0), "error": bool(r.error)})
    if not rows:
        raise RuntimeError("sweep: no trial reported a result (see the Ray logs under the experiment folder)")
    rows.sort(key=lambda row: row["trial"])      # the order Optuna proposed them in
    fields = list(rows[0])
    with (out / f"{spec.name}_trials.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fields)
        w.writeheader()
        for row in rows:
            w.writerow({k: json.dumps(v) if isinstance(v, list) else v for k, v in row.items()})
    done = [row for row in rows if not row["stopped_early"]] or rows
    best = max(done, key=lambda row: (row["goal"], -row["collision"]))
    cfg = trial_config(spec.base_config, {k: best[k] for k in spec.space}, spec)
    best_cfg = {**cfg.to_dict(), "eval_every": spec.base_config.get("eval_every", 0),
                "checkpoint_every": spec.base_config.get("checkpoint_every", 0),
                "tensorboard": True, "threads": spec.base_config.get("threads", 1)}
    header = (f"# Best trial of sweep '{spec.name}' ({len(rows)} trials): trial {best['trial']} ({best['trial_id']}),\n"
              f"# goal {100 * best['goal']:.1f} % / collision {100 * best['collision']:.1f} % on {spec.eval_episodes} "
              f"held-out missions (eval_seed {spec.eval_seed}) after {best['env_steps']} env steps.\n"
              f"# Swept: {', '.join(spec.space)}. Train it: train --config THIS_FILE --out runs/{spec.name}_best\n")
    (out / f"{spec.name}_best.yaml").write_text(header + yaml.safe_dump(best_cfg, sort_keys=False))
    plot(spec, rows, out / f"{spec.name}.png", load_reference(spec, out))
    return best


def importance(spec: SweepSpec, rows: list[dict]) -> dict[str, float]:
    """Optuna's parameter importance (its default evaluator) of each swept key for the objective."""
    import optuna
    from optuna.distributions import CategoricalDistribution, FloatDistribution, IntDistribution
    dists = {}
    for key, dist in spec.space.items():
        kind, args = next(iter(dist.items()))
        if kind in ("uniform", "loguniform"):
            dists[key] = FloatDistribution(float(args[0]), float(args[1]), log=kind == "loguniform")
        elif kind == "randint":
            dists[key] = IntDistribution(int(args[0]), int(args[1]))
        else:
            dists[key] = CategoricalDistribution([_encode(a) for a in args])
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(direction="maximize")
    for row in rows:
        study.add_trial(optuna.trial.create_trial(params={k: _encode(row[k]) for k in spec.space},
                                                  distributions=dists, value=float(row["goal"])))
    if len(rows) < 2 or len(spec.space) < 2:
        return {k: 1.0 / len(spec.space) for k in spec.space}
    return dict(optuna.importance.get_param_importances(study))


def plot(spec: SweepSpec, rows: list[dict], path: Path, reference: dict | None = None) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 4.5))
    x = [r["trial"] for r in rows]
    y = [100 * r["goal"] for r in rows]
    early = [r["stopped_early"] for r in rows]
    a1.scatter([xi for xi, e in zip(x, early) if not e], [yi for yi, e in zip(y, early) if not e],
               label="full budget", zorder=3)
    a1.scatter([xi for xi, e in zip(x, early) if e], [yi for yi, e in zip(y, early) if e], marker="x",
               label="stopped early (ASHA)", zorder=3)
    a1.plot(x, np.maximum.accumulate(y), color="k", lw=1, label="best so far")
    if reference is not None:
        a1.axhline(100 * reference["goal"], color="tab:red", ls="--", lw=1, label="base config (--reference)")
    a1.set_xlabel("trial")
    a1.set_ylabel(f"goal rate on {spec.eval_episodes} held-out missions (%)")
    a1.legend()
    imp = importance(spec, rows)
    keys = sorted(imp, key=imp.get)
    a2.barh(keys, [imp[k] for k in keys])
    a2.set_xlabel("importance for the goal rate (Optuna)")
    fig.suptitle(f"sweep {spec.name}: {len(rows)} trials")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--config", required=True, help="sweep YAML (base, space, trials, ...)")
    ap.add_argument("--out", default="runs/sweeps", help="folder for the experiment and its results")
    ap.add_argument("--address", default=None, help="Ray cluster address ('auto' = the running one); default: local")
    ap.add_argument("--trials", type=int, help="override the file's trial count")
    ap.add_argument("--results", action="store_true",
                    help="only write the table, best YAML and PNG from the experiment as it stands (no new trials)")
    ap.add_argument("--reference", action="store_true",
                    help="only train the base config under the trial protocol (no Ray) and write <name>_reference.json")
    ap.add_argument("--quiet", action="store_true")
    a = ap.parse_args(argv)
    try:
        spec = load_spec(a.config)
        if a.trials is not None:
            spec.trials = a.trials
        if a.reference:
            ref = run_reference(spec, Path(a.out), progress=not a.quiet)
            print(f"base config: goal {100 * ref['goal']:.1f} % collision {100 * ref['collision']:.1f} % after "
                  f"{ref['env_steps']} env steps; wrote {a.out}/{spec.name}_reference.json")
            return 0
        if any(importlib.util.find_spec(m) is None for m in ("ray", "optuna")):
            raise RuntimeError(INSTALL_HINT)
        out = Path(a.out)
        grid = saved_results(spec, out) if a.results else run_sweep(spec, out, a.address, progress=not a.quiet)
        best = write_results(spec, grid, out)
    except (ValueError, OSError, RuntimeError) as err:
        print(f"sweep: {err}", file=sys.stderr)
        return 2
    print(f"best trial {best['trial']}: goal {100 * best['goal']:.1f} % collision {100 * best['collision']:.1f} % "
          f"({', '.join(f'{k}={best[k]}' for k in spec.space)}); wrote {out}/{spec.name}_trials.csv, "
          f"{spec.name}_best.yaml, {spec.name}.png")
    ref = load_reference(spec, out)
    if ref is not None:
        print(f"base config (--reference): goal {100 * ref['goal']:.1f} % collision {100 * ref['collision']:.1f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
