"""Two drivers' failures mission by mission: which missions one completes that the other does not.

Why: a matrix cell says how often each driver fails, not whether they fail the same missions. Two
drivers at 98.5 % can share every failure or none, and that decides what to work on: a shield that
rescues 31 of the raw policy's misses in a cell but loses 8 missions the raw policy completes
(its overrides send the vehicle off a line that was safe) needs other work than one that only
rescues. Every ``evaluate --matrix`` row lists its failed missions (``failed``: index, outcome,
decisions; a cell's mission ``i`` is the same for every driver of the same matrix, seed and count),
so two rows, of one file or two, compare here. Pure Python: reads the JSONs ``evaluate`` wrote.

    python -m cage_reactive_ddpg.failure_overlap runs/m.json:raw runs/m.json:shield
    python -m cage_reactive_ddpg.failure_overlap a.json:shield b.json:shield --out docs/results/overlap.md
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .matrix import driver_rows, emit

#: What must match for mission ``i`` of cell ``k`` to be the same mission in both files.
SAME_MISSIONS = ("matrix", "seed", "episodes", "planner")


class OverlapError(ValueError):
    """A file or row that cannot be compared; the message names it and says why."""


def read_side(spec: str) -> tuple[str, dict, dict[int, dict[int, str]]]:
    """``PATH:DRIVER`` -> (label, the file's header, {cell: {mission index: outcome}} of the driver's
    failures). A row written before rows listed their failures (session 51) cannot be compared."""
    try:
        path, data, rows = driver_rows(spec)
    except ValueError as err:
        raise OverlapError(str(err)) from None
    driver = rows[0]["driver"]
    failed: dict[int, dict[int, str]] = {}
    for r in rows:
        if "failed" not in r:
            raise OverlapError(f"{path}: cell {r['cell']} {driver} lists no failed missions (a file written "
                               "before session 51 without --failures): run the cell again")
        failed[int(r["cell"])] = {int(f["index"]): str(f["outcome"]) for f in r["failed"]}
    return f"{Path(path).stem}:{driver}", {k: data.get(k) for k in SAME_MISSIONS}, failed


def compare(a: dict[int, dict[int, str]], b: dict[int, dict[int, str]]) -> list[dict]:
    """Per cell both sides ran: how many missions each failed, failed both, and only one of them
    (``only_a``: B completes them, ``only_b``: B fails where A did not), with the indices."""
    rows = []
    for cell in sorted(set(a) & set(b)):
        fa, fb = set(a[cell]), set(b[cell])
        rows.append({"cell": cell, "a_failed": len(fa), "b_failed": len(fb), "both": len(fa & fb),
                     "only_a": sorted(fa - fb), "only_b": sorted(fb - fa)})
    return rows


def table(rows: list[dict], label_a: str, label_b: str, shown: int = 12) -> str:
    """Markdown: one line per cell and a total line; at most ``shown`` indices per list."""
    def idx(v: list[int]) -> str:
        return ", ".join(map(str, v[:shown])) + (f", ... ({len(v)})" if len(v) > shown else "")
    out = [f"A = `{label_a}`, B = `{label_b}`: missions each failed, failed by both, and by one only.", "",
           "| cell | A failed | B failed | both | A only (B completes) | B only (A completes) | A-only missions | B-only missions |",
           "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {r['cell']} | {r['a_failed']} | {r['b_failed']} | {r['both']} | {len(r['only_a'])} | "
                   f"{len(r['only_b'])} | {idx(r['only_a'])} | {idx(r['only_b'])} |")
    tot = {k: sum(r[k] for r in rows) for k in ("a_failed", "b_failed", "both")}
    out.append(f"| all | {tot['a_failed']} | {tot['b_failed']} | {tot['both']} | "
               f"{sum(len(r['only_a']) for r in rows)} | {sum(len(r['only_b']) for r in rows)} | | |")
    return "\n".join(out) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("a", help="PATH:DRIVER, e.g. runs/m.json:raw")
    ap.add_argument("b", help="PATH:DRIVER, e.g. runs/m.json:shield")
    ap.add_argument("--out", help="also write the table here (markdown)")
    a = ap.parse_args(argv)
    try:
        label_a, head_a, fa = read_side(a.a)
        label_b, head_b, fb = read_side(a.b)
        if head_a != head_b:
            diff = ", ".join(f"{k} {head_a[k]!r} vs {head_b[k]!r}" for k in SAME_MISSIONS if head_a[k] != head_b[k])
            raise OverlapError(f"not the same missions: {diff}")
        rows = compare(fa, fb)
        if not rows:
            raise OverlapError(f"no cell in both: A has {sorted(fa)}, B has {sorted(fb)}")
    except OverlapError as err:
        print(f"failure_overlap: {err}", file=sys.stderr)
        return 2
    emit(table(rows, label_a, label_b), a.out,
         f"### Failures mission by mission ({', '.join(f'{k} {head_a[k]}' for k in SAME_MISSIONS)})\n\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
