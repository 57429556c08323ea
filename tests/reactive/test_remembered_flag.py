"""``evaluate --remembered``: the files say which remembered returns the shield and the baseline
counted (``cleared`` by default since session 53), rows flown with another setting are not merged or
pooled with them, and a raw policy's rows, which no setting changes, are not kept apart."""
import json

from cage_reactive_ddpg.evaluate import main as evaluate
from cage_reactive_ddpg.mission_sets import main as pool


def test_rows_of_the_other_setting_are_neither_merged_nor_pooled(tmp_path, capsys):
    args = ["--matrix", "tiny", "--episodes", "4", "--quiet", "--drivers", "baseline", "--sensor", "multibeam360"]
    assert evaluate([*args, "--seed", "6", "--remembered", "out_of_view", "--out", str(tmp_path / "oov")]) == 0
    assert evaluate([*args, "--seed", "7", "--remembered", "all", "--out", str(tmp_path / "all")]) == 0
    assert evaluate([*args, "--seed", "8", "--out", str(tmp_path / "default")]) == 0
    oov, every, default = (json.loads((tmp_path / f"{n}.json").read_text()) for n in ("oov", "all", "default"))
    assert oov["remembered"] == "out_of_view" and "remembered" not in every and default["remembered"] == "cleared"
    assert "remembered returns out_of_view" in (tmp_path / "oov.md").read_text()
    capsys.readouterr()
    assert evaluate([*args, "--seed", "6", "--reuse", str(tmp_path / "oov.json"), "--out", str(tmp_path / "m")]) == 2
    assert "remembered is 'out_of_view' there, 'cleared' here" in capsys.readouterr().err
    assert pool([f"x={tmp_path / 'oov.json'}:baseline,{tmp_path / 'all.json'}:baseline", "--cells", "0"]) == 2
    assert "in remembered" in capsys.readouterr().err


def test_raw_rows_record_no_setting_and_pool_across_settings(tmp_path, capsys):
    args = ["--matrix", "tiny", "--episodes", "3", "--quiet", "--drivers", "raw", "--cells", "0"]
    assert evaluate([*args, "--seed", "6", "--out", str(tmp_path / "a")]) == 0
    assert evaluate([*args, "--seed", "7", "--remembered", "out_of_view", "--out", str(tmp_path / "b")]) == 0
    assert all("remembered" not in json.loads((tmp_path / f"{n}.json").read_text()) for n in "ab")
    capsys.readouterr()
    assert pool([f"raw={tmp_path / 'a.json'}:raw,{tmp_path / 'b.json'}:raw", "--cells", "0"]) == 0
    assert "raw" in capsys.readouterr().out
