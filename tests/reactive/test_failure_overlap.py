"""failure_overlap: two matrix rows compared mission by mission name the very missions one driver
completes and the other fails (flown again alone with ``--only``, they end so), and files that
cannot be compared are one clear line."""
import json

import pytest
import torch
from cage_sim.mission import EnvConfig

from cage_reactive_ddpg.evaluate import main as evaluate
from cage_reactive_ddpg.failure_overlap import compare, main
from cage_reactive_ddpg.networks import Actor
from cage_reactive_ddpg.policy import save_policy


@pytest.fixture(scope="module")
def flown(tmp_path_factory):
    """An untrained actor behind the shield (it completes some missions, not most) and the baseline
    on the same tiny matrix."""
    tmp = tmp_path_factory.mktemp("overlap")
    torch.manual_seed(3)
    save_policy(tmp / "untrained.safetensors", Actor(EnvConfig().layout.size, (16, 8)), {"note": "untrained"})
    args = ["--matrix", "tiny", "--episodes", "10", "--seed", "6", "--quiet"]
    assert evaluate([*args, "--drivers", "shield,baseline", "--policy", str(tmp / "untrained.safetensors"),
                     "--out", str(tmp / "m")]) == 0
    return tmp, args


def test_the_missions_one_driver_alone_fails_are_those_it_fails_flown_again(flown, capsys):
    tmp, args = flown
    rows = json.loads((tmp / "m.json").read_text())["rows"]
    assert main([f"{tmp / 'm.json'}:shield", f"{tmp / 'm.json'}:baseline", "--out", str(tmp / "o.md")]) == 0
    failed = {(r["cell"], r["driver"]): {f["index"] for f in r["failed"]} for r in rows}
    got = compare({c: dict.fromkeys(failed[c, "shield"], "x") for c in (0, 1)},
                  {c: dict.fromkeys(failed[c, "baseline"], "x") for c in (0, 1)})
    for r in got:
        assert r["a_failed"] == 10 - next(x["goal"] for x in rows if (x["cell"], x["driver"]) == (r["cell"], "shield"))
        assert r["both"] + len(r["only_a"]) == r["a_failed"] and r["both"] + len(r["only_b"]) == r["b_failed"]
    cell = max(got, key=lambda r: len(r["only_a"]))
    completed = sorted(set(range(10)) - failed[cell["cell"], "shield"])
    assert len(cell["only_a"]) >= 3 and len(completed) >= 2     # some missions each way
    for missions, shield_goals in ((cell["only_a"], 0), (completed, len(completed))):
        redo = tmp / f"redo{shield_goals}"
        assert evaluate([*args, "--drivers", "shield,baseline", "--policy", str(tmp / "untrained.safetensors"),
                         "--cells", str(cell["cell"]), "--only", ",".join(map(str, missions)),
                         "--out", str(redo)]) == 0
        again = {r["driver"]: r for r in json.loads(redo.with_suffix(".json").read_text())["rows"]}
        assert again["shield"]["goal"] == shield_goals
        if shield_goals == 0:
            assert again["baseline"]["goal"] == len(missions)    # the baseline completes every one
    text = (tmp / "o.md").read_text()
    assert "| all |" in text and "seed 6" in text and capsys.readouterr().out.count("| all |") == 1


def test_files_that_cannot_be_compared_are_refused_in_one_line(flown, tmp_path, capsys):
    tmp, _ = flown
    m = tmp / "m.json"
    assert main([f"{m}:shield", f"{m}:raw"]) == 2
    assert "no 'raw' rows (drivers there: baseline, shield)" in capsys.readouterr().err
    data = json.loads(m.read_text())
    old = {**data, "rows": [{k: v for k, v in r.items() if k != "failed"} for r in data["rows"]]}
    (tmp_path / "old.json").write_text(json.dumps(old))
    assert main([f"{tmp_path / 'old.json'}:shield", f"{m}:baseline"]) == 2
    assert "lists no failed missions" in capsys.readouterr().err
    (tmp_path / "other.json").write_text(json.dumps({**data, "seed": 7}))
    assert main([f"{tmp_path / 'other.json'}:shield", f"{m}:baseline"]) == 2
    assert "not the same missions: seed 7 vs 6" in capsys.readouterr().err
    assert main([str(m), f"{m}:shield"]) == 2 and "expected PATH:DRIVER" in capsys.readouterr().err
