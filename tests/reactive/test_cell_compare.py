"""cell_compare: two drivers flown on the same missions, cell by cell, from the files ``evaluate
--matrix`` wrote; a matrix flown in parts reads as one, and sides of other missions are refused."""
import json

import pytest

from cage_reactive_ddpg.cell_compare import CompareError, compare, main, read_side
from cage_reactive_ddpg.evaluate import main as evaluate


@pytest.fixture(scope="module")
def flown(tmp_path_factory):
    """The raw study policy and the baseline on the tiny matrix (seed 5), the policy in two parts,
    and the baseline again on seed 6."""
    tmp = tmp_path_factory.mktemp("compare")
    common = ["--matrix", "tiny", "--episodes", "10", "--quiet"]
    for name, extra in (("raw0", ["--drivers", "raw", "--cells", "0", "--seed", "5"]),
                        ("raw1", ["--drivers", "raw", "--cells", "1", "--seed", "5"]),
                        ("base", ["--drivers", "baseline", "--seed", "5"]),
                        ("base6", ["--drivers", "baseline", "--seed", "6"])):
        assert evaluate([*common, *extra, "--out", str(tmp / name)]) == 0
    return tmp


def test_the_counts_follow_the_goals_of_each_cell(flown, capsys):
    label, kind, raw = read_side(f"raw={flown / 'raw0.json'}:raw,{flown / 'raw1.json'}:raw")
    _, _, base = read_side(f"b={flown / 'base.json'}:baseline")
    assert label == "raw" and kind["seed"] == 5 and sorted(raw) == [0, 1]
    rows, counts = compare(raw, base, [0, 1])
    for r in rows:
        assert r["goal_diff"] == raw[r["cell"]]["goal"] - base[r["cell"]]["goal"]
    assert sum(counts.values()) == 2
    assert counts["more"] == sum(r["goal_diff"] > 0 for r in rows) and counts["fewer"] == sum(r["goal_diff"] < 0 for r in rows)
    assert main([f"raw={flown / 'raw0.json'}:raw,{flown / 'raw1.json'}:raw", f"b={flown / 'base.json'}:baseline",
                 "--out", str(flown / "c.md")]) == 0
    text = (flown / "c.md").read_text()
    assert text == capsys.readouterr().out and text.count("\n| 0 |") + text.count("\n| 1 |") == 2
    totals = [sum(raw[c][k] for c in (0, 1)) for k in ("goal", "collision")]
    assert f"| all | | {totals[0]} / {totals[1]} /" in text


def test_sides_of_other_missions_and_cells_given_twice_are_refused(flown, capsys):
    assert main([f"raw={flown / 'raw0.json'}:raw", f"b={flown / 'base6.json'}:baseline"]) == 2
    assert "different missions (seed)" in capsys.readouterr().err
    with pytest.raises(CompareError, match="cell 0 given twice"):
        read_side(f"raw={flown / 'raw0.json'}:raw,{flown / 'raw0.json'}:raw")
    with pytest.raises(CompareError, match="of other missions than the side's first file .seed."):
        read_side(f"b={flown / 'base.json'}:baseline,{flown / 'base6.json'}:baseline")
    with pytest.raises(CompareError, match="no 'shield' rows"):
        read_side(f"b={flown / 'base.json'}:shield")
    assert main([f"raw={flown / 'raw0.json'}:raw", f"b={flown / 'base.json'}:baseline", "--cells", "1"]) == 2
    assert "cells [1]: not in both sides" in capsys.readouterr().err
    assert json.loads((flown / "raw0.json").read_text())["rows"][0]["cell"] == 0
