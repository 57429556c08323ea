"""One driver's outcome in a cell over several mission sets: each set's count and the pooled rate.

Why: a target such as ">= 99 % goal in every cell" is judged on one set of 1000 missions per cell,
and in the hardest cells (0.5 m/s, goal by the net) one driver moves by up to 1 point between two
sets (``docs/results/tune_goal_in_sight_s47.md``, session 50's seed screen): a 98.6 % on one set
and a 99.2 % on another say little about which driver is better, or whether either is above the
line. Flying the same cells on more mission seeds (``evaluate --matrix ... --seed S --cells 19,23``)
and pooling them narrows the interval: 4000 missions give about +-0.3 points at 99 % where 1000
give +-0.6. This reads the JSONs ``evaluate --matrix`` wrote (one group of files per driver) and
says, per cell, each set's goals / collisions / timeouts, the pooled rates with 95 % Wilson
intervals, and whether the pooled goal rate is above, below or not yet told apart from the line.
Pure Python.

    python -m cage_reactive_ddpg.mission_sets \\
        "mb360 driver=docs/results/matrix_sea_shield_mb360_s46.json:shield,runs/h7001.json:shield" \\
        "fls driver=..." --cells 19,23 --goal 99 --out docs/results/hard_cells.md
"""
from __future__ import annotations

import argparse
import sys

from .evaluate import READS_REMEMBERED, wilson
from .matrix import driver_rows, emit, parse_cells

#: What must match for two files to be sets of the same missions' kind (the seed must differ).
#: ``observation``: the layout the drivers read. A baseline run with ``--sensor`` and no policy reads
#: the plain scan, one beside a policy reads that policy's scan, memory and velocity: not one driver.
SAME_KIND = ("matrix", "episodes", "planner", "replan", "known_map", "sensor", "observation", "grace", "remembered")


class SetsError(ValueError):
    """A group, file or row that cannot be pooled; the message names it and says why."""


def read_group(spec: str) -> tuple[str, list[dict]]:
    """``LABEL=PATH:DRIVER[,PATH:DRIVER...]`` -> (label, one record per file: its seed, policy text
    and {cell: row} of the driver). Refused: a file of another kind of missions than the first
    (``SAME_KIND``) and a seed given twice (the same missions would count twice)."""
    label, sep, files = spec.partition("=")
    if not sep or not label.strip() or not files:
        raise SetsError(f"{spec!r}: expected LABEL=PATH:DRIVER[,PATH:DRIVER...]")
    sets: list[dict] = []
    for item in files.split(","):
        try:
            path, data, chosen = driver_rows(item)
        except ValueError as err:
            raise SetsError(f"{label}: {err}") from None
        rows = {int(r["cell"]): r for r in chosen}
        reads = any(r["driver"] in READS_REMEMBERED for r in chosen)   # a raw row: any setting's file
        kind = {k: data.get(k) for k in SAME_KIND if k != "remembered" or reads}
        if sets and kind != sets[0]["kind"]:
            diff = [k for k in SAME_KIND if kind.get(k) != sets[0]["kind"].get(k)]
            raise SetsError(f"{label}: {path} differs from {sets[0]['path']} in {', '.join(diff)}")
        if any(s["seed"] == data.get("seed") for s in sets):
            raise SetsError(f"{label}: seed {data.get('seed')} given twice ({path}): the same missions")
        sets.append({"path": path, "seed": data.get("seed"), "policy": str(data.get("policy")),
                     "kind": kind, "rows": rows})
    return label.strip(), sets


def pool(sets: list[dict], cell: int) -> dict | None:
    """The cell's counts per set and pooled, or None when a set lacks the cell."""
    rows = [s["rows"].get(cell) for s in sets]
    if any(r is None for r in rows):
        return None
    total = {o: sum(int(r.get(o, 0)) for r in rows) for o in ("goal", "collision", "timeout", "wander")}
    n = sum(int(r["episodes"]) for r in rows)
    return {"cell": cell, "per_set": [(s["seed"], r["goal"], r["collision"], r["timeout"]) for s, r in zip(sets, rows)],
            "n": n, **total, "goal_ci": wilson(total["goal"], n), "collision_ci": wilson(total["collision"], n)}


def verdict(lo: float, hi: float, line: float, above_is_good: bool = True) -> str:
    """Whether an interval [lo, hi] (fractions) lies on the good side of ``line`` (a fraction)."""
    if lo >= line if above_is_good else hi <= line:
        return "met"
    if hi < line if above_is_good else lo > line:
        return "missed"
    return "not told apart"


def markdown(groups: list[tuple[str, list[dict]]], cells: list[int], goal: float, collision: float) -> str:
    head = (f"### Pooled over mission sets: goal >= {goal:g} %, collision <= {collision:g} %\n\n"
            "| driver | cell | per set (seed: goals / collisions / timeouts) | pooled of N | goal % [95 % CI] | "
            "collision % [95 % CI] | goal line | collision line |\n|---|---|---|---|---|---|---|---|")
    lines, sources = [head], []
    for label, sets in groups:
        for cell in cells:
            p = pool(sets, cell)
            if p is None:
                lines.append(f"| {label} | {cell} | not in every set | | | | | |")
                continue
            (glo, ghi), (clo, chi) = p["goal_ci"], p["collision_ci"]
            per = ", ".join(f"{s}: {g} / {c} / {t}" for s, g, c, t in p["per_set"])
            lines.append(f"| {label} | {cell} | {per} | {p['goal']} / {p['collision']} / {p['timeout']} of {p['n']} | "
                         f"{100 * p['goal'] / p['n']:.2f} [{100 * glo:.2f}, {100 * ghi:.2f}] | "
                         f"{100 * p['collision'] / p['n']:.2f} [{100 * clo:.2f}, {100 * chi:.2f}] | "
                         f"{verdict(glo, ghi, goal / 100)} | {verdict(clo, chi, collision / 100, above_is_good=False)} |")
        sources += [f"- {label}, seed {s['seed']}: `{s['path']}` ({s['policy']})" for s in sets]
    return "\n".join(lines + ["", "Sources:", *sources]) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("groups", nargs="+", help="LABEL=PATH:DRIVER[,PATH:DRIVER...]: one driver's files, one per mission seed")
    ap.add_argument("--cells", required=True, help="cells to pool, e.g. 19,23 or 16-23")
    ap.add_argument("--goal", type=float, default=99.0, help="goal line in %% (default 99)")
    ap.add_argument("--collision", type=float, default=0.5, help="collision line in %% (default 0.5)")
    ap.add_argument("--out", help="also write the table to this markdown file")
    args = ap.parse_args(argv)
    try:
        cells = parse_cells(args.cells, 10 ** 6)
        groups = [read_group(g) for g in args.groups]
    except (SetsError, ValueError) as err:
        print(f"mission_sets: {err}", file=sys.stderr)
        return 2
    emit(markdown(groups, cells, args.goal, args.collision), args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
