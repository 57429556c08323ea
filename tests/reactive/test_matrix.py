"""Sea conditions and the evaluation matrix: cells draw what they say, the CLI writes its tables."""
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from cage_reactive_ddpg.evaluate import main
from cage_reactive_ddpg.matrix import NEAR_NET, Condition, parse_condition
from cage_reactive_ddpg.missions import episode_scenarios


def test_a_cell_draws_its_conditions():
    c = parse_condition("sea:current=0.5,obstacles=small,goal=near_net,schools=2")
    assert c == Condition(0.5, "small", "near_net", 2)
    for sc in episode_scenarios(c.name, 5, seed=1):
        w = sc.world
        assert np.isclose(np.hypot(*w.current), 0.5)              # the uniform part; 20 % varies on top
        assert abs(w.net.clearance(*sc.goal) - NEAR_NET) < 0.1       # from the wall the sonar sees
        assert w.unknown and all(0.15 <= (o.size if o.shape == "circle" else o.size / 2) <= 0.3 for o in w.unknown)
        assert len(w.schools) == 2


def test_bad_cells_are_refused_naming_the_key():
    with pytest.raises(ValueError, match="current"):
        parse_condition("sea:current=1.2")
    with pytest.raises(ValueError, match="colour: unknown sea condition key"):
        parse_condition("sea:colour=red")
    with pytest.raises(ValueError, match="obstacles"):
        Condition(obstacles="huge")


def test_cli_tiny_matrix_writes_tables_and_figure(tmp_path, capsys):
    prefix, png = tmp_path / "m", tmp_path / "m.png"
    assert main(["--matrix", "tiny", "--episodes", "2", "--seed", "5",
                 "--drivers", "baseline", "--out", str(prefix), "--plot", str(png), "--quiet"]) == 0
    rows = json.loads(prefix.with_suffix(".json").read_text())["rows"]
    assert [r["cell"] for r in rows] == [0, 1] and all(r["episodes"] == 2 for r in rows)
    assert all(sum(r[o] for o in ("goal", "collision", "wander", "timeout")) == 2 for r in rows)
    csv = prefix.with_suffix(".csv").read_text().splitlines()
    assert csv[0].startswith("cell,current") and len(csv) == 3
    assert "| 0.5 | small | near_net | 1 |" in prefix.with_suffix(".md").read_text()
    assert png.stat().st_size > 1000
    assert "baseline: goal %" in capsys.readouterr().out
    # The shipped policy on the same missions, the baseline's rows reused from the first run.
    both = tmp_path / "both"
    assert main(["--matrix", "tiny", "--episodes", "2", "--seed", "5", "--drivers", "raw,baseline",
                 "--reuse", str(prefix.with_suffix(".json")), "--out", str(both), "--quiet"]) == 0
    rows2 = json.loads(both.with_suffix(".json").read_text())["rows"]
    assert [(r["cell"], r["driver"]) for r in rows2] == [(0, "raw"), (0, "baseline"), (1, "raw"), (1, "baseline")]
    assert [r for r in rows2 if r["driver"] == "baseline"] == rows
    assert main(["--matrix", "tiny", "--episodes", "3", "--seed", "5", "--reuse", str(prefix.with_suffix(".json")),
                 "--quiet"]) == 2


def test_cli_matrix_failures_name_and_plot_each_cells_misses(tmp_path):
    """``--failures PREFIX``: each row lists its failed missions by index, and a cell and driver with
    any get a PNG of their tracks; a still-water policy in the tiny matrix's 0.5 m/s cell misses."""
    from cage_reactive_ddpg.policy import shipped_path
    prefix, fails = tmp_path / "m", tmp_path / "fail"
    calm = str(shipped_path().with_name("policy_calm.safetensors"))
    assert main(["--matrix", "tiny", "--episodes", "6", "--seed", "5", "--drivers", "raw", "--policy", calm,
                 "--out", str(prefix), "--failures", str(fails), "--quiet"]) == 0
    rows = json.loads(prefix.with_suffix(".json").read_text())["rows"]
    assert sum(len(r["failed"]) for r in rows) > 0
    for r in rows:
        assert len(r["failed"]) == r["episodes"] - r["goal"]
        assert all(0 <= f["index"] < 6 for f in r["failed"])
        png = tmp_path / f"fail_cell{r['cell']}_raw.png"
        assert png.exists() == bool(r["failed"])
    # the misses flown again by themselves: the same outcomes, to the decision
    row = next(r for r in rows if r["failed"])
    again = tmp_path / "again"
    assert main(["--matrix", "tiny", "--episodes", "6", "--seed", "5", "--drivers", "raw", "--policy", calm,
                 "--cells", str(row["cell"]), "--only", ",".join(str(f["index"]) for f in row["failed"]),
                 "--out", str(again), "--trace", str(tmp_path / "trace.csv"), "--quiet"]) == 0
    (redo,) = json.loads(again.with_suffix(".json").read_text())["rows"]
    assert redo["episodes"] == len(row["failed"]) and redo["goal"] == 0
    assert all(redo[o] == sum(f["outcome"] == o for f in row["failed"]) for o in ("collision", "wander", "timeout"))
    # --trace: each miss decision by decision, with its cell, driver, index and the outcome it ended in
    import csv
    trace = list(csv.DictReader((tmp_path / "trace.csv").open()))
    assert {(r["cell"], r["driver"]) for r in trace} == {(str(row["cell"]), "raw")}
    ends = {int(r["episode"]): (r["outcome"], int(r["decision"]) + 1) for r in trace if r["outcome"]}
    assert ends == {f["index"]: (f["outcome"], f["steps"]) for f in row["failed"]}
    assert main(["--matrix", "tiny", "--episodes", "6", "--seed", "5", "--drivers", "raw", "--policy", calm,
                 "--only", "1", "--reuse", str(prefix.with_suffix(".json")), "--quiet"]) == 2


def test_cli_unknown_matrix_or_driver_is_one_line(capsys):
    assert main(["--matrix", "nope", "--quiet"]) == 2
    assert "matrix: 'nope'" in capsys.readouterr().err
    assert main(["--matrix", "tiny", "--drivers", "magic", "--quiet"]) == 2
    assert "--drivers: unknown ['magic']" in capsys.readouterr().err


def test_cli_cells_run_in_parts_merge_into_the_whole_matrix(tmp_path):
    """``--cells`` keeps each cell's missions, so two parts merged with ``--reuse`` are the whole run."""
    args = ["--matrix", "tiny", "--episodes", "2", "--seed", "5", "--policy", "baseline", "--drivers", "baseline",
            "--quiet"]
    whole, a, b, merged = (tmp_path / n for n in ("whole", "a", "b", "merged"))
    assert main(args + ["--out", str(whole)]) == 0
    assert main(args + ["--cells", "1", "--out", str(b)]) == 0
    assert main(args + ["--cells", "0", "--out", str(a)]) == 0
    rows_b = json.loads(b.with_suffix(".json").read_text())["rows"]
    assert [r["cell"] for r in rows_b] == [1]
    assert main(args + ["--reuse", f"{b.with_suffix('.json')},{a.with_suffix('.json')}", "--out", str(merged)]) == 0
    load = lambda p: json.loads(p.with_suffix(".json").read_text())["rows"]  # noqa: E731
    assert load(merged) == load(whole)
    assert main(args + ["--cells", "0-5"]) == 2          # outside the matrix: one line, no run


def test_the_baseline_reads_the_policys_observation_whichever_drivers_run(tmp_path):
    """A matrix run in parts must compare like with like: the baseline run alone reads the shipped
    policy's scan, memory and velocity as it does beside the policy (before session 25 it fell back
    to the study's v1 scan alone), and rows read through another observation are not reused."""
    args = ["--matrix", "tiny", "--episodes", "2", "--seed", "5", "--cells", "1", "--quiet"]
    alone, beside, v1 = (tmp_path / n for n in ("alone", "beside", "v1"))
    assert main(args + ["--drivers", "baseline", "--out", str(alone)]) == 0
    assert main(args + ["--drivers", "raw,baseline", "--out", str(beside)]) == 0
    load = lambda p: json.loads(p.with_suffix(".json").read_text())  # noqa: E731
    a, b = load(alone), load(beside)
    assert a["observation"] == b["observation"] and a["observation"]["name"] == "cage-obs-v2"
    assert a["observation"]["memory_bins"] > 0
    assert a["rows"] == [r for r in b["rows"] if r["driver"] == "baseline"]
    assert main(args + ["--policy", "baseline", "--drivers", "baseline", "--out", str(v1)]) == 0
    assert load(v1)["observation"]["name"] == "cage-obs-v1"
    assert main(args + ["--drivers", "raw,baseline", "--reuse", str(v1.with_suffix(".json"))]) == 2
    fls = tmp_path / "fls"                # --sensor with no policy named: the baseline on that sonar alone
    assert main(args + ["--drivers", "baseline", "--sensor", "fls", "--out", str(fls)]) == 0
    assert load(fls)["sensor"] == "fls" and load(fls)["observation"] != a["observation"]


def test_a_sensor_with_no_policy_flies_that_profiles_shipped_driver(tmp_path, capsys):
    """``--sensor fls`` and no ``--policy``: the raw rows are the fls driver's (``policy.DRIVERS``),
    and the file names its weights, so they merge only with rows of that file."""
    from cage_reactive_ddpg.policy import shipped_path
    args = ["--matrix", "tiny", "--episodes", "2", "--seed", "5", "--cells", "0", "--quiet", "--drivers", "raw"]
    by_sensor, by_file = tmp_path / "by_sensor", tmp_path / "by_file"
    assert main(args + ["--sensor", "fls", "--out", str(by_sensor)]) == 0
    assert main(args + ["--policy", str(shipped_path("fls")), "--out", str(by_file)]) == 0
    load = lambda p: json.loads(p.with_suffix(".json").read_text())  # noqa: E731
    assert load(by_sensor)["sensor"] == "fls" and load(by_sensor)["rows"] == load(by_file)["rows"]
    assert load(by_sensor)["policy"] == str(shipped_path("fls"))
    reuse = ["--reuse", str(by_sensor.with_suffix(".json")), "--out", str(tmp_path / "m")]
    assert main(args + reuse + ["--sensor", "fls"]) == 0             # the same driver: merged
    near = str(shipped_path("fls").with_name("policy_fls_near.safetensors"))
    assert main(args + reuse + ["--policy", near]) == 2              # another fls policy: refused, named
    assert f"{shipped_path('fls').name}'s" in capsys.readouterr().err


def test_markdown_of_merged_parts_marks_a_missing_driver_row():
    """Rows merged from parts (``--reuse``) may hold a driver in some cells only: the table shows
    '-' there instead of failing."""
    from cage_reactive_ddpg.matrix import markdown
    row = {"current": 0.5, "obstacles": "small", "goal_at": "any", "schools": 0, "episodes": 10,
           "goal": 9, "collision": 1}
    md = markdown([{**row, "cell": 0, "driver": "baseline"}, {**row, "cell": 1, "driver": "baseline"},
                   {**row, "cell": 1, "driver": "shield", "goal": 10, "collision": 0}], "t")
    lines = [ln for ln in md.splitlines() if ln.startswith("| 0.5")]
    assert len(lines) == 2 and lines[0].endswith("| - | - |") and "100.0" in lines[1]


def test_shield_rows_are_reused_only_with_the_same_known_map_setting(tmp_path, capsys):
    """The known map changes the shield's rows only: a shield row flown with ``--known-map off`` is
    not merged into a run with the map (one line naming ``known_map``); raw and baseline rows are."""
    args = ["--matrix", "tiny", "--episodes", "2", "--seed", "5", "--cells", "0", "--quiet"]
    off, plain = tmp_path / "off", tmp_path / "plain"
    assert main(args + ["--drivers", "shield", "--known-map", "off", "--out", str(off)]) == 0
    assert json.loads(off.with_suffix(".json").read_text())["known_map"] == "off"
    assert main(args + ["--drivers", "shield,baseline", "--reuse", str(off.with_suffix(".json"))]) == 2
    assert "known_map is 'off' there, 'on' here" in capsys.readouterr().err
    assert main(args + ["--drivers", "baseline", "--known-map", "off", "--out", str(plain)]) == 0
    assert main(args + ["--drivers", "raw,baseline", "--reuse", str(plain.with_suffix(".json"))]) == 0


def test_policy_rows_are_reused_only_for_the_policy_named(tmp_path, capsys):
    """Raw and shield rows belong to one weights file: merged into a run of another policy (here the
    default's, named by no --policy) they are refused, naming both; the baseline's rows are not."""
    from cage_reactive_ddpg.policy import shipped_path
    other = str(shipped_path().with_name("policy_near.safetensors"))
    args = ["--matrix", "tiny", "--episodes", "2", "--seed", "5", "--cells", "0", "--quiet"]
    raw, merged = tmp_path / "raw", tmp_path / "merged"
    assert main(args + ["--drivers", "raw,baseline", "--policy", other, "--out", str(raw)]) == 0
    assert main(args + ["--drivers", "raw,baseline", "--reuse", str(raw.with_suffix(".json"))]) == 2
    assert "policy_near.safetensors's" in capsys.readouterr().err
    assert main(args + ["--drivers", "raw,baseline", "--policy", other, "--reuse", str(raw.with_suffix(".json")),
                        "--out", str(merged)]) == 0                     # the same policy: merged
    again = json.loads(merged.with_suffix(".json").read_text())
    assert again["rows"] == json.loads(raw.with_suffix(".json").read_text())["rows"]
    assert main(args + ["--drivers", "raw,baseline", "--policy", other, "--out", str(tmp_path / "m2"),
                        "--reuse", str(merged.with_suffix(".json"))]) == 0   # a merged file names it too
    copy = tmp_path / "copy.safetensors"                 # the same weights elsewhere (a run folder's)
    copy.write_bytes(Path(other).read_bytes())
    shutil.copy(Path(other).with_suffix(".json"), copy.with_suffix(".json"))
    assert main(args + ["--drivers", "raw", "--policy", str(copy), "--out", str(tmp_path / "m3"),
                        "--reuse", str(raw.with_suffix(".json"))]) == 0
    shipped = tmp_path / "shipped"               # the default's raw rows, first: the other file's are not taken
    assert main(args + ["--drivers", "raw", "--out", str(shipped)]) == 0
    assert main(args + ["--drivers", "raw,baseline", "--out", str(tmp_path / "m4"),
                        "--reuse", f"{shipped.with_suffix('.json')},{raw.with_suffix('.json')}"]) == 0



def test_an_out_prefix_with_a_dot_keeps_it(tmp_path):
    """``--out runs/p0.5`` writes ``p0.5.md/.csv/.json`` (it wrote ``p0.*`` before: the dot read as
    a suffix); ``--out m.json`` still names the set ``m.*``."""
    args = ["--matrix", "tiny", "--episodes", "1", "--seed", "5", "--drivers", "baseline", "--cells", "0", "--quiet"]
    assert main([*args, "--out", str(tmp_path / "p0.5")]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p0.5.csv", "p0.5.json", "p0.5.md"]
    assert main([*args, "--out", str(tmp_path / "m.json")]) == 0
    assert {"m.csv", "m.json", "m.md"} <= {p.name for p in tmp_path.iterdir()}
