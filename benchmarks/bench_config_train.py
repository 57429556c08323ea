"""Training throughput of a shipped config, this tree against a reference tree, side by side.

What the 30-minute training target rests on: env steps per second of ``train`` on a real config
(the env with its sensor profile and memory, the expert's rollouts, the scenario generators, the
updates), one thread, evaluation and TensorBoard off. Each run is a fresh process; runs of the two
trees alternate so machine load hits both alike. CPU seconds (the child's user + system time) are
the figure to compare on a shared machine; wall seconds are printed too.

The reference tree is any checkout of this repository, e.g. the commit before a speed change:

  git worktree add /tmp/ref HEAD~1
  python benchmarks/bench_config_train.py --config ros2_ws/src/cage_reactive_ddpg/config/sea_guided_scanning.yaml \\
      --steps 40000 --reference /tmp/ref --repeats 2

``--workers 1,2`` runs this tree once per value of ``env_workers`` (2: the envs and the expert in
two worker processes, the networks in the trainer: both cores busy; then wall time is the figure,
on a machine with nothing else running). Prints one line per run, the medians, the ratios against
the reference and one JSON line; with ``--budget`` the projected wall time of that many steps.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("ros2_ws/src/cage_sim", "ros2_ws/src/cage_reactive_ddpg", "ros2_ws/src/cage_global_rrt", "runtime/src")

CHILD = """
import json, sys, tempfile
from pathlib import Path
import cage_sim, cage_reactive_ddpg
from cage_reactive_ddpg import config as config_mod
from cage_reactive_ddpg.train import Trainer
over = {"total_steps": int(sys.argv[2]), "eval_episodes": 0, "tensorboard": False, "threads": 1,
        "eval_every": 10**12, "checkpoint_every": 10**12, "seed": int(sys.argv[3])}
if int(sys.argv[4]) > 1:
    over["env_workers"] = int(sys.argv[4])
cfg = config_mod.build(file=sys.argv[1], overrides=over)
with tempfile.TemporaryDirectory() as d:
    tr = Trainer(cfg, Path(d), progress=False)
    tr.run()
print(json.dumps({"env_steps": tr.step, "updates": tr.updates, "train_seconds": tr.train_seconds,
                  "source": str(Path(cage_sim.__file__).resolve().parents[1])}))
"""


def run_tree(tree: Path, config: Path, steps: int, seed: int, workers: int = 1) -> dict:
    """One training run in a fresh process importing the packages of ``tree``; its CPU time (its env
    worker processes included) and wall time."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(str(tree / p) for p in PACKAGES),
               OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", CHILD, str(config), str(steps), str(seed), str(workers)], env=env, check=True,
                         capture_output=True, text=True, cwd=tree)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    r = json.loads(out.stdout.strip().splitlines()[-1])
    if Path(r["source"]).resolve() != (tree / "ros2_ws/src/cage_sim").resolve():
        raise RuntimeError(f"{tree}: imported cage_sim from {r['source']}, not from this tree")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {**r, "wall_seconds": wall, "cpu_seconds": cpu, "steps_per_cpu_s": r["env_steps"] / cpu,
            "steps_per_s": r["env_steps"] / r["train_seconds"]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--config", default="ros2_ws/src/cage_reactive_ddpg/config/sea_guided_scanning.yaml")
    ap.add_argument("--steps", type=int, default=40000, help="env steps per run (the config's prefill included)")
    ap.add_argument("--reference", default=None, help="another checkout of the repository to compare against")
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--budget", type=int, default=None, help="project the wall time of this many steps")
    ap.add_argument("--workers", default="1", help="env_workers values to run this tree with (e.g. 1,2); the "
                                                   "reference runs with one process")
    a = ap.parse_args(argv)
    config = Path(a.config).resolve()
    workers = [int(w) for w in a.workers.split(",")]
    trees = {("this" if w == 1 else f"this-w{w}"): (ROOT, w) for w in workers}
    if a.reference:
        trees["reference"] = (Path(a.reference).resolve(), 1)
    runs: dict[str, list[dict]] = {k: [] for k in trees}
    for rep in range(a.repeats):
        for name, (tree, w) in trees.items():
            r = run_tree(tree, config, a.steps, seed=rep, workers=w)
            runs[name].append(r)
            print(f"[{name} rep {rep}] {r['env_steps']} steps, {r['updates']} updates: {r['cpu_seconds']:.1f} CPU s "
                  f"({r['steps_per_cpu_s']:.1f} steps/CPU s), {r['wall_seconds']:.1f} s wall", flush=True)
    med = {k: {m: float(np.median([r[m] for r in v])) for m in ("steps_per_cpu_s", "steps_per_s", "cpu_seconds")}
           for k, v in runs.items()}
    print(f"{'run':<12}{'steps/CPU s':>13}{'steps/s wall':>14}")
    for k, m in med.items():
        print(f"{k:<12}{m['steps_per_cpu_s']:>13.1f}{m['steps_per_s']:>14.1f}")
    out = {"bench": "config_train", "config": str(Path(a.config)), "steps": a.steps, "repeats": a.repeats,
           "results": med, "load_1min": os.getloadavg()[0]}
    if "reference" in med:
        for k in med:
            if k != "reference":
                cpu = med[k]["steps_per_cpu_s"] / med["reference"]["steps_per_cpu_s"]
                wall = med[k]["steps_per_s"] / med["reference"]["steps_per_s"]
                print(f"ratio {k} / reference: steps per CPU s x{cpu:.2f}, steps per wall s x{wall:.2f}")
                out[f"ratio_{k}"] = {"steps_per_cpu_s": cpu, "steps_per_s": wall}
    if a.budget:
        for k in med:
            minutes = a.budget / med[k]["steps_per_s"] / 60
            print(f"{a.budget} steps at {k}'s wall rate: {minutes:.1f} min")
            out[f"projected_minutes_{k}"] = minutes
    print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
