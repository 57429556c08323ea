"""Learning curve of a training run (also one stopped before its budget): moving goal and collision
rates of the training episodes against wall time, and the periodic evaluations.

    .venv/bin/python benchmarks/plot_learning_curve.py runs/sea_study docs/figures/learning_curve_sea_study.png

Reads ``episodes.csv`` and the ``evaluations`` recorded in ``best.json`` (or ``policy.json``) of the
run folder; prints one JSON line with the last evaluation and the time it took.
"""
from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main(run: str, png: str, window: int = 200) -> int:
    d = Path(run)
    rows = list(csv.DictReader((d / "episodes.csv").open()))
    meta_file = d / "policy.json" if (d / "policy.json").is_file() else d / "best.json"
    evals = json.loads(meta_file.read_text()).get("evaluations", []) if meta_file.is_file() else []
    t = np.array([float(r["seconds"]) for r in rows]) / 60
    goal = np.array([r["outcome"] == "goal" for r in rows], float)
    coll = np.array([r["outcome"] == "collision" for r in rows], float)
    k = np.ones(window) / window
    fig, ax = plt.subplots(figsize=(7, 4))
    if len(rows) >= window:
        ax.plot(t[window - 1:], 100 * np.convolve(goal, k, "valid"), label=f"training goal % (last {window})")
        ax.plot(t[window - 1:], 100 * np.convolve(coll, k, "valid"), label="training collision %")
    if evals:
        te = [e["seconds"] / 60 for e in evals]
        ax.plot(te, [100 * e["rates"]["goal"] for e in evals], "o-", label=f"evaluation goal % ({evals[0]['scenario']})")
        ax.plot(te, [100 * e["rates"]["collision"] for e in evals], "s-", label="evaluation collision %")
    ax.set_xlabel("wall time (min, 2 shared cores)")
    ax.set_ylabel("%")
    ax.set_ylim(0, 100)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    steps = max((int(r["step"]) for r in rows), default=0)
    ax.set_title(f"{d.name}: {len(rows)} episodes, {steps} env steps")
    fig.tight_layout()
    Path(png).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=90)
    last = evals[-1] if evals else {}
    print(json.dumps({"run": str(d), "episodes": len(rows), "env_steps": steps, "minutes": round(float(t[-1]), 1) if len(t) else 0,
                      "last_eval": {k: last.get(k) for k in ("step", "seconds", "rates", "scenario")}}))
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:3]))
