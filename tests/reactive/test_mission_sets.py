"""mission_sets: one driver's rows over several mission seeds pool into the sums of what was flown,
with a narrower interval than any one set's, and files that cannot be pooled are one clear line."""
import json

import pytest

from cage_reactive_ddpg.evaluate import main as evaluate
from cage_reactive_ddpg.evaluate import wilson
from cage_reactive_ddpg.mission_sets import main, pool, read_group, verdict


@pytest.fixture(scope="module")
def sets(tmp_path_factory):
    """The classical baseline on the tiny matrix, two mission seeds of 12 missions each."""
    tmp = tmp_path_factory.mktemp("sets")
    for seed in (6, 7):
        assert evaluate(["--matrix", "tiny", "--episodes", "12", "--seed", str(seed), "--quiet",
                         "--drivers", "baseline", "--out", str(tmp / f"m{seed}")]) == 0
    return tmp


def test_the_pooled_counts_are_the_sums_of_the_sets_flown(sets, capsys):
    rows = {seed: {r["cell"]: r for r in json.loads((sets / f"m{seed}.json").read_text())["rows"]} for seed in (6, 7)}
    label, group = read_group(f"base={sets / 'm6.json'}:baseline,{sets / 'm7.json'}:baseline")
    assert label == "base" and [s["seed"] for s in group] == [6, 7]
    for cell in (0, 1):
        p = pool(group, cell)
        a, b = rows[6][cell], rows[7][cell]
        assert p["n"] == 24
        for o in ("goal", "collision", "timeout", "wander"):
            assert p[o] == a[o] + b[o]
        assert p["per_set"] == [(6, a["goal"], a["collision"], a["timeout"]), (7, b["goal"], b["collision"], b["timeout"])]
        lo, hi = p["goal_ci"]
        for one in (a, b):                            # twice the missions: a narrower interval than either set's
            one_lo, one_hi = wilson(one["goal"], one["episodes"])
            assert hi - lo < one_hi - one_lo
    assert main([f"base={sets / 'm6.json'}:baseline,{sets / 'm7.json'}:baseline", "--cells", "0,1", "--goal", "0",
                 "--out", str(sets / "pooled.md")]) == 0
    text = (sets / "pooled.md").read_text()
    assert text == capsys.readouterr().out
    assert text.count("| base |") == 2 and "of 24 |" in text and "| met |" in text   # any rate is >= 0 %
    assert "seed 6: `" in text and "seed 7: `" in text


def test_the_verdict_says_which_side_of_the_line_the_interval_lies():
    assert verdict(0.991, 0.996, 0.99) == "met"
    assert verdict(0.975, 0.989, 0.99) == "missed"
    assert verdict(0.985, 0.993, 0.99) == "not told apart"
    assert verdict(0.001, 0.004, 0.005, above_is_good=False) == "met"
    assert verdict(0.006, 0.012, 0.005, above_is_good=False) == "missed"


def test_sets_that_cannot_be_pooled_are_refused_in_one_line(sets, tmp_path, capsys):
    m6 = sets / "m6.json"
    assert main([f"x={m6}:baseline,{m6}:baseline", "--cells", "0"]) == 2
    assert "seed 6 given twice" in capsys.readouterr().err
    other = {**json.loads(m6.read_text()), "seed": 8, "episodes": 20}
    (tmp_path / "other.json").write_text(json.dumps(other))
    assert main([f"x={m6}:baseline,{tmp_path / 'other.json'}:baseline", "--cells", "0"]) == 2
    assert "differs from" in capsys.readouterr().err
    plain = {**json.loads(m6.read_text()), "seed": 9, "observation": {"name": "another layout"}}
    (tmp_path / "plain.json").write_text(json.dumps(plain))
    assert main([f"x={m6}:baseline,{tmp_path / 'plain.json'}:baseline", "--cells", "0"]) == 2
    assert "in observation" in capsys.readouterr().err
    assert main([f"x={m6}:raw", "--cells", "0"]) == 2 and "no 'raw' rows" in capsys.readouterr().err
    assert main([f"{m6}:baseline", "--cells", "0"]) == 2 and "expected LABEL=" in capsys.readouterr().err
    assert main([f"x={m6}:baseline", "--cells", "0", "--goal", "0"]) == 0
    assert main([f"x={m6}:baseline", "--cells", "5"]) == 0 and "not in every set" in capsys.readouterr().out
