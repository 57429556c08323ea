"""``evaluate --remembered out_of_view``: the files say so, and rows flown with every remembered
return are not merged or pooled with them."""
import json

from cage_reactive_ddpg.evaluate import main as evaluate
from cage_reactive_ddpg.mission_sets import main as pool


def test_rows_of_the_other_setting_are_neither_merged_nor_pooled(tmp_path, capsys):
    args = ["--matrix", "tiny", "--episodes", "4", "--quiet", "--drivers", "baseline", "--sensor", "multibeam360"]
    assert evaluate([*args, "--seed", "6", "--remembered", "out_of_view", "--out", str(tmp_path / "oov")]) == 0
    assert evaluate([*args, "--seed", "7", "--out", str(tmp_path / "all")]) == 0
    oov, every = (json.loads((tmp_path / f"{n}.json").read_text()) for n in ("oov", "all"))
    assert oov["remembered"] == "out_of_view" and "remembered" not in every
    assert "remembered returns out_of_view" in (tmp_path / "oov.md").read_text()
    capsys.readouterr()
    assert evaluate([*args, "--seed", "6", "--reuse", str(tmp_path / "oov.json"), "--out", str(tmp_path / "m")]) == 2
    assert "remembered is 'out_of_view' there, 'all' here" in capsys.readouterr().err
    assert pool([f"x={tmp_path / 'oov.json'}:baseline,{tmp_path / 'all.json'}:baseline", "--cells", "0"]) == 2
    assert "in remembered" in capsys.readouterr().err
