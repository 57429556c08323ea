"""A raw residual policy flown with its base controller reading a chosen memory setting (probe).

Why: since session 53 the shield and the baseline count the remembered returns ``cleared`` by
default, and the baseline gained more than the raw policy it is compared with. A raw residual
policy's base was trained reading every remembered return (``all``); this flies the same policy
with its base reading another setting, on the sea-matrix cells given, to see whether the policy
keeps the base's gain. Prints one line per cell (goals / collisions / timeouts / wanders) and the
totals; rows go to ``--out`` as JSON. Never run as a test; the evaluator's ``--matrix`` is the
tool for shipped settings.

    .venv/bin/python benchmarks/probe_raw_base.py --policy W --cells 16-23 [--seed 4242]
        [--episodes 1000] [--remembered cleared] [--out runs/probe.json]
"""
from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--policy", required=True, help="a residual policy's weights file")
    ap.add_argument("--cells", default="16-23", help="sea-matrix cells (as evaluate --cells)")
    ap.add_argument("--seed", type=int, default=4242, help="mission seed (default: the tuning seed)")
    ap.add_argument("--episodes", type=int, default=1000)
    ap.add_argument("--remembered", default="cleared", help="the base's setting (cage_sim.controller.REMEMBERED)")
    ap.add_argument("--out", default=None, help="JSON file for the rows")
    a = ap.parse_args()

    from cage_reactive_ddpg import matrix as mx
    from cage_reactive_ddpg.policy import env_config_for, load_policy
    pol = load_policy(a.policy)
    if pol.residual_base is None:
        ap.error(f"--policy {a.policy}: not a residual policy (no base to set)")
    pol.residual_base = dataclasses.replace(pol.residual_base, remembered=a.remembered)
    env = env_config_for(pol.metadata, None)
    _, cells = mx.load_matrix("sea")
    wanted = set(mx.parse_cells(a.cells, len(cells)))
    skip = {(k, "raw") for k in range(len(cells)) if k not in wanted}
    rows = mx.run_matrix(cells, {"raw": pol}, a.episodes, a.seed, "rrt", env, replan=True, skip=skip)
    keys = ("goal", "collision", "timeout", "wander")
    for r in rows:
        print(f"cell {r['cell']}: " + " / ".join(str(r[k]) for k in keys))
    print(f"total ({a.remembered}): " + " / ".join(str(sum(r[k] for r in rows)) for k in keys))
    if a.out:
        Path(a.out).write_text(json.dumps({"policy": a.policy, "seed": a.seed, "episodes": a.episodes,
                                           "base_remembered": a.remembered, "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
