"""Two drivers cell by cell on the same missions: goals, collisions and timeouts side by side.

Why: issue 9's raw target is "better than the classical baseline in every cell", and each session
counted by hand, from two matrix JSONs, in how many cells the raw policy has more, fewer or the
same goals as the baseline. This reads the files ``evaluate --matrix`` wrote (one ``PATH:DRIVER``
per side, several files per side when a matrix was flown in parts), refuses two sides flown on
different missions (seed, episodes, cells' kind), and prints the table with the counts. Pure Python.

    python -m cage_reactive_ddpg.cell_compare \\
        "raw=runs/a.json:raw,runs/b.json:raw" "baseline=docs/results/matrix_sea_baseline_cleared_s54.json:baseline" \\
        --out docs/results/compare.md
"""
from __future__ import annotations

import argparse
import sys

from .matrix import driver_rows, emit, parse_cells

#: What two sides must share to be the same missions (the drivers and their settings may differ).
SAME_MISSIONS = ("matrix", "episodes", "seed", "planner", "replan", "sensor")


class CompareError(ValueError):
    """A side that cannot be compared; the message names it and says why."""


def read_side(spec: str) -> tuple[str, dict, dict[int, dict]]:
    """``LABEL=PATH:DRIVER[,PATH:DRIVER...]`` -> (label, the missions' kind, {cell: row}); a cell
    given by two files, or files of different missions, is refused."""
    label, sep, files = spec.partition("=")
    if not sep or not label.strip() or not files:
        raise CompareError(f"{spec!r}: expected LABEL=PATH:DRIVER[,PATH:DRIVER...]")
    kind: dict | None = None
    rows: dict[int, dict] = {}
    for item in files.split(","):
        try:
            path, data, chosen = driver_rows(item)
        except ValueError as err:
            raise CompareError(f"{label}: {err}") from None
        mine = {k: data.get(k) for k in SAME_MISSIONS}
        if kind is not None and mine != kind:
            raise CompareError(f"{label}: {path} is of other missions than the side's first file "
                               f"({', '.join(k for k in SAME_MISSIONS if mine[k] != kind[k])})")
        kind = mine
        for r in chosen:
            if int(r["cell"]) in rows:
                raise CompareError(f"{label}: cell {r['cell']} given twice ({path})")
            rows[int(r["cell"])] = r
    return label.strip(), kind or {}, rows


def compare(a: dict[int, dict], b: dict[int, dict], cells: list[int]) -> tuple[list[dict], dict[str, int]]:
    """Per cell: both sides' goals / collisions / timeouts (+ wanders) and which has more goals;
    the counts of cells where ``a`` has more, fewer or as many goals as ``b``."""
    out, counts = [], {"more": 0, "fewer": 0, "level": 0}
    for c in cells:
        ra, rb = a[c], b[c]
        d = int(ra["goal"]) - int(rb["goal"])
        verdict = "more" if d > 0 else "fewer" if d < 0 else "level"
        counts[verdict] += 1
        out.append({"cell": c, "a": ra, "b": rb, "goal_diff": d, "collision_diff": int(ra["collision"]) - int(rb["collision"]),
                    "verdict": verdict})
    return out, counts


def _cell(r: dict) -> str:
    return f"{r['goal']} / {r['collision']} / {int(r['timeout']) + int(r.get('wander', 0))}"


def _label(r: dict) -> str:
    return f"{r['current']:g} m/s, {r['obstacles']}, goal {r['goal_at']}, {r['schools']} schools"


def markdown(la: str, lb: str, kind: dict, rows: list[dict], counts: dict[str, int]) -> str:
    """The table: one line per cell, then the totals and the counts."""
    lines = [f"### {la} against {lb}: {kind.get('matrix')} matrix, sensor {kind.get('sensor')}, "
             f"{kind.get('episodes')} missions per cell, seed {kind.get('seed')}",
             "", "Goals / collisions / timeouts (+ wanders) of each cell's missions.", "",
             f"| cell | condition | {la} | {lb} | goals | collisions |", "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['cell']} | {_label(r['a'])} | {_cell(r['a'])} | {_cell(r['b'])} | "
                     f"{r['goal_diff']:+d} | {r['collision_diff']:+d} |")
    sums = {s: [sum(int(r[s]["goal"]) for r in rows), sum(int(r[s]["collision"]) for r in rows),
                sum(int(r[s]["timeout"]) + int(r[s].get("wander", 0)) for r in rows)] for s in ("a", "b")}
    lines.append(f"| all | | {' / '.join(map(str, sums['a']))} | {' / '.join(map(str, sums['b']))} | "
                 f"{sums['a'][0] - sums['b'][0]:+d} | {sums['a'][1] - sums['b'][1]:+d} |")
    lines += ["", f"{la} has more goals than {lb} in {counts['more']} cells, fewer in {counts['fewer']}, "
                  f"as many in {counts['level']} (of {len(rows)})."]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("a", help="LABEL=PATH:DRIVER[,PATH:DRIVER...]: the first side (e.g. the raw policy)")
    ap.add_argument("b", help="LABEL=PATH:DRIVER[,...]: the side it is compared with (e.g. the baseline)")
    ap.add_argument("--cells", help="cells to compare (default: every cell both sides have)")
    ap.add_argument("--out", help="also write the table to this markdown file")
    args = ap.parse_args(argv)
    try:
        la, ka, a = read_side(args.a)
        lb, kb, b = read_side(args.b)
        if ka != kb:
            raise CompareError(f"{la} and {lb} were flown on different missions "
                               f"({', '.join(k for k in SAME_MISSIONS if ka[k] != kb[k])})")
        both = sorted(set(a) & set(b))
        cells = parse_cells(args.cells, max(set(a) | set(b)) + 1) if args.cells else both
        missing = [c for c in cells if c not in a or c not in b]
        if not cells or missing:
            raise CompareError(f"cells {missing or 'none'}: not in both sides")
    except (CompareError, ValueError) as err:
        print(f"cell_compare: {err}", file=sys.stderr)
        return 2
    rows, counts = compare(a, b, cells)
    emit(markdown(la, lb, ka, rows, counts), args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
