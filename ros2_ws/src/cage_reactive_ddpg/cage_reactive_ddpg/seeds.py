"""Several seeds of one config: train each, evaluate each on held-out episodes, report the spread.

Why: one seed says little about an RL method (papers that quote the best of five seeds are the
field's main reproducibility complaint). ``train --seeds N`` trains seeds ``seed .. seed+N-1`` of the
same config into ``OUT/seed_<s>/`` (as Ray tasks, one CPU and one torch thread each, when Ray is
installed; one after another otherwise), then writes

  OUT/seeds.json   per seed: the final evaluation (rates, 95 % Wilson intervals); over seeds: mean,
                   min, max and standard deviation of every outcome rate
  OUT/seeds.md     the same as a markdown table
  OUT/seeds.png    learning curves (moving-average reward and success vs env steps): the mean over
                   seeds and the min-max band

The evaluation is the trainer's final one: ``eval_episodes`` missions drawn from the trainer's
evaluation seed, disjoint from every training episode. ``aggregate`` works on any set of run folders.
"""
from __future__ import annotations

import importlib.util
import json
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np

from . import config as config_mod
from .config import TrainConfig
from .evaluate import wilson


def ray_available() -> bool:
    return importlib.util.find_spec("ray") is not None


def train_one(cfg_dict: dict, out: str, command: str, progress: bool = False) -> dict:
    """Train one config into ``out``; return its final evaluation (runs in a Ray worker or here)."""
    from .train import Trainer
    cfg = config_mod.from_dict(cfg_dict)
    tr = Trainer(cfg, Path(out), command, progress=progress)
    return tr.run()


def seed_dirs(out: Path, cfg: TrainConfig, n: int) -> list[tuple[TrainConfig, Path]]:
    runs = []
    for k in range(n):
        c = config_mod.apply(config_mod.from_dict(cfg.to_dict()), {"seed": cfg.seed + k})
        runs.append((c, out / f"seed_{c.seed}"))
    return runs


def train_seeds(cfg: TrainConfig, out: Path, n: int, command: str = "", use_ray: bool = True,
                progress: bool = True, address: str | None = None) -> int:
    """Train ``n`` seeds and aggregate them (see the module doc). Returns the exit code."""
    if n < 1:
        raise ValueError("--seeds: must be >= 1")
    runs = seed_dirs(out, cfg, n)
    out.mkdir(parents=True, exist_ok=True)
    if use_ray and ray_available():
        import ray
        ray.init(address=address or os.environ.get("RAY_ADDRESS"), include_dashboard=False,
                 log_to_driver=False, configure_logging=False)
        task = ray.remote(num_cpus=1)(train_one)
        print(f"seeds: {n} runs as Ray tasks on {ray.cluster_resources().get('CPU', 0):.0f} CPUs", file=sys.stderr)
        ray.get([task.remote({**c.to_dict(), "threads": 1}, str(d), command) for c, d in runs])
    else:
        why = "" if use_ray is False else " (Ray not installed: bash scripts/setup.sh --with-ray)"
        print(f"seeds: {n} runs one after another{why}", file=sys.stderr)
        for c, d in runs:
            train_one(c.to_dict(), str(d), command, progress=progress)
    summary = aggregate([d for _, d in runs], out)
    print(table(summary))
    return 0


def _final_eval(run: Path) -> dict:
    meta = json.loads((run / "policy.json").read_text())
    ev = meta.get("evaluation") or {}
    if "rates" not in ev or not ev["rates"]:
        raise ValueError(f"{run}: its policy.json has no final evaluation (eval_episodes = 0?)")
    n = int(ev.get("episodes") or 0)
    ci = ev.get("ci95") or {o: list(wilson(round(r * n), n)) for o, r in ev["rates"].items()}
    return {"seed": meta["config"]["seed"], "episodes": n, "rates": ev["rates"],
            "ci95": ci, "env_steps": meta["training"]["env_steps"],
            "seconds": meta["training"]["seconds"]}


def aggregate(runs: list[Path], out: Path | None = None) -> dict[str, Any]:
    """Mean/min/max/std over seeds of each outcome rate, plus every seed's rates and intervals;
    written to ``out``/seeds.json, .md and .png when ``out`` is given."""
    summary = over_seeds([_final_eval(Path(r)) for r in runs], runs)
    if out is not None:
        write(summary, Path(out), "seeds")
        plot_band([Path(r) for r in runs], Path(out) / "seeds.png")
    return summary


def over_seeds(per: list[dict], runs: list) -> dict[str, Any]:
    """The summary both ``aggregate`` and ``reevaluate`` write: per-seed rows, then each outcome's
    mean, min, max and standard deviation over the seeds."""
    over = {}
    for o in per[0]["rates"]:
        v = np.array([p["rates"][o] for p in per], dtype=float)
        over[o] = {"mean": float(v.mean()), "min": float(v.min()), "max": float(v.max()),
                   "std": float(v.std(ddof=1)) if len(v) > 1 else 0.0}
    return {"seeds": [p["seed"] for p in per], "runs": [str(r) for r in runs], "per_seed": per,
            "over_seeds": over, "episodes_per_seed": per[0]["episodes"]}


def write(summary: dict, out: Path, stem: str) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{stem}.json").write_text(json.dumps(summary, indent=2))
    (out / f"{stem}.md").write_text(table(summary) + "\n")


def reused_rows(files: list[Path], episodes: int, seed: int, scenario: str, planner: str, weights: str,
                shield: bool) -> dict[str, dict]:
    """Rows of earlier ``reevaluate`` JSONs flown on the same missions by the same driver, by run
    folder (the first file's row wins). A file of another driver (weights, shield) gives none: the
    raw and shielded files are passed together. A file of other missions is refused, naming the
    field, as ``evaluate --reuse`` refuses one: it is a wrong file, not one to skip unseen.

    Why: a seed trained in a later session joins the table without flying the earlier seeds again
    (1000 missions, raw and shielded, are minutes per seed)."""
    missions = {"episodes_per_seed": episodes, "eval_seed": seed, "scenario": scenario, "planner": planner}
    driver = {"weights": weights, "shield": shield}
    rows: dict[str, dict] = {}
    for f in files:
        s = json.loads(Path(f).read_text())
        diffs = [f"{k} {s.get(k)!r} (this run: {v!r})" for k, v in missions.items() if s.get(k) != v]
        if diffs:
            raise ValueError(f"--reuse {f}: flown on other missions: " + ", ".join(diffs))
        if all(s.get(k) == v for k, v in driver.items()):
            for run, row in zip(s["runs"], s["per_seed"]):
                rows.setdefault(str(Path(run)), row)
    return rows


def reevaluate(runs: list[Path], episodes: int, seed: int, scenario: str, planner: str = "rrt",
               weights: str = "policy", shield: bool = False, reuse: dict[str, dict] | None = None) -> dict[str, Any]:
    """Every run's policy (``weights``: ``policy`` = the final one, ``best`` = the trainer's best
    checkpoint) on the same ``episodes`` missions drawn from ``seed``, raw or behind the shield.

    Why: the trainer's own evaluation is a few hundred episodes (a 95 % interval of +-3 points at
    93 %), too coarse to tell seeds apart, and the best checkpoint was chosen on it; fresh missions
    from a seed never used in training give each seed a tight, unbiased figure. ``reuse``
    (``reused_rows``): the runs found there are not flown again."""
    from .evaluate import evaluate, load_driver
    from .policy import env_config_for
    per = []
    for r in runs:
        r = Path(r)
        if reuse and str(r) in reuse:
            per.append(reuse[str(r)])
            print(f"[{r}] {weights}{' + shield' if shield else ''}: reused", file=sys.stderr, flush=True)
            continue
        driver, _, meta = load_driver(str(r / f"{weights}.safetensors"), shield=shield)
        env = env_config_for(meta)                    # the policy's own sensor, layout and motion
        summary, _, _ = evaluate(driver, scenario, episodes, seed, env.motion, planner, keep_tracks=0, env=env)
        per.append({"seed": meta["config"]["seed"], "episodes": episodes, "rates": summary["rates"],
                    "ci95": summary["ci95"], "weights": weights, "shield": shield})
        print(f"[{r}] {weights}{' + shield' if shield else ''}: goal {100 * summary['rates']['goal']:.1f} %, "
              f"collision {100 * summary['rates']['collision']:.1f} %", file=sys.stderr, flush=True)
    s = over_seeds(per, runs)
    s.update(scenario=scenario, eval_seed=seed, planner=planner, weights=weights, shield=shield)
    return s


def table(s: dict) -> str:
    """Markdown: one row per seed (rate and 95 % interval of goal and collision), then mean/min/max."""
    lines = [f"{len(s['seeds'])} seeds, {s['episodes_per_seed']} held-out evaluation episodes each",
             "", "| seed | goal | goal 95 % CI | collision | collision 95 % CI |", "|---:|---:|---|---:|---|"]
    for p in s["per_seed"]:
        g, c = p["rates"]["goal"], p["rates"].get("collision", 0.0)
        gi, ci = p["ci95"].get("goal", [g, g]), p["ci95"].get("collision", [c, c])
        lines.append(f"| {p['seed']} | {100 * g:.1f} % | [{100 * gi[0]:.1f}, {100 * gi[1]:.1f}] | "
                     f"{100 * c:.1f} % | [{100 * ci[0]:.1f}, {100 * ci[1]:.1f}] |")
    for stat in ("mean", "min", "max"):
        o = s["over_seeds"]
        lines.append(f"| **{stat}** | {100 * o['goal'][stat]:.1f} % | | "
                     f"{100 * o.get('collision', {}).get(stat, 0.0):.1f} % | |")
    return "\n".join(lines)


def _curve(run: Path, window: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int] | None:
    from .train import read_rows
    rows = read_rows(run / "episodes.csv", 10 ** 12)
    if len(rows) < 2:
        return None
    k = min(window, max(1, len(rows) // 4))     # short runs: a shorter window, still a curve
    steps = np.array([r["step"] for r in rows], float)
    rew = np.convolve([r["reward"] for r in rows], np.ones(k) / k, mode="valid")
    suc = np.convolve([r["success"] for r in rows], np.ones(k) / k, mode="valid")
    return steps[k - 1:], rew, suc, k


def plot_band(runs: list[Path], path: Path, window: int = 100) -> None:
    """Moving-average reward and success of each seed on a common env-step grid: mean and min-max."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    curves = [c for c in (_curve(r, window) for r in runs) if c is not None]
    if not curves:
        return
    lo, hi = max(c[0][0] for c in curves), min(c[0][-1] for c in curves)
    if hi <= lo:
        return
    grid = np.linspace(lo, hi, 200)
    k = min(c[3] for c in curves)
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    for ax, j, label in ((axes[0], 1, "reward"), (axes[1], 2, "success rate")):
        ys = np.array([np.interp(grid, c[0], c[j]) for c in curves])
        ax.fill_between(grid, ys.min(0), ys.max(0), alpha=0.3, label=f"min-max over {len(curves)} seeds")
        ax.plot(grid, ys.mean(0), lw=1.8, label="mean")
        ax.set_xlabel("env steps")
        ax.set_ylabel(f"{label} (moving average, {k} episodes)")
        ax.legend()
    fig.suptitle(f"{len(curves)} seeds")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    """``python -m cage_reactive_ddpg.seeds --out DIR RUN [RUN ...]``: aggregate run folders trained
    apart (e.g. seeds spread over machines or sessions) exactly as ``train --seeds`` does. With
    ``--evaluate N``: also run every seed's final and best policy, raw and shielded, on the same N
    fresh missions (``--eval-seed``, ``--scenario``) into DIR/seeds_<weights>_<raw|shield>.json|md."""
    import argparse
    ap = argparse.ArgumentParser(description=main.__doc__)
    ap.add_argument("runs", nargs="+", help="run folders, each with its policy.json and episodes.csv")
    ap.add_argument("--out", required=True, help="folder for seeds.json, seeds.md and seeds.png")
    ap.add_argument("--evaluate", type=int, default=0, metavar="N", help="fresh missions per seed and driver")
    ap.add_argument("--eval-seed", type=int, default=2026)
    ap.add_argument("--scenario", default="sea_dr")
    ap.add_argument("--planner", default="rrt")
    ap.add_argument("--weights", default="policy,best", help="with --evaluate: policy (final), best, or both")
    ap.add_argument("--reuse", default="", help="with --evaluate: seeds_*.json files (comma-separated) of "
                    "earlier evaluations; a run already flown there on the same missions by the same "
                    "driver is not flown again")
    a = ap.parse_args(argv)
    try:
        out, runs = Path(a.out), [Path(r) for r in a.runs]
        print(table(aggregate(runs, out)))
        for weights in a.weights.split(",") if a.evaluate else ():
            if weights not in ("policy", "best"):
                raise ValueError(f"--weights: {weights!r} is neither policy nor best")
            for shield in (False, True):
                done = reused_rows([Path(f) for f in a.reuse.split(",") if f], a.evaluate, a.eval_seed,
                                   a.scenario, a.planner, weights, shield)
                s = reevaluate(runs, a.evaluate, a.eval_seed, a.scenario, a.planner, weights, shield, done)
                write(s, out, f"seeds_{weights}_{'shield' if shield else 'raw'}")
                print(f"\n{weights} weights{' + shield' if shield else ', raw'} on {a.evaluate} {a.scenario} "
                      f"missions (seed {a.eval_seed}):\n{table(s)}")
    except (OSError, ValueError, KeyError, RuntimeError) as err:
        print(f"seeds: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
