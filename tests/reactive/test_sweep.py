"""Seeds and sweeps: several seeds aggregate into mean/min/max with per-seed intervals and a band plot;
a 2-trial Ray Tune + Optuna sweep runs on a local Ray instance, writes its table, best config and
PNG, and resumes instead of starting over (skipped only when Ray is not installed)."""
import csv
import importlib.util
import json

import pytest

from cage_reactive_ddpg import config as config_mod
from cage_reactive_ddpg.seeds import main as seeds_main
from cage_reactive_ddpg.seeds import train_seeds
from cage_reactive_ddpg.sweep import load_spec
from cage_reactive_ddpg.sweep import main as sweep_main
from cage_reactive_ddpg.train import main as train_main

TINY_1D = {"scenario": "study1d", "total_steps": 600, "n_envs": 4, "prefill_steps": 100, "actor_hidden": [16, 16],
           "critic_hidden": [16, 16], "batch_size": 32, "buffer_size": 2000, "eval_episodes": 30,
           "tensorboard": False, "noise": "gaussian", "lr_actor": 1e-3, "gamma": 0.5}


def test_seeds_aggregate_mean_min_max_and_band(tmp_path, capsys):
    cfg = config_mod.build("study", overrides={**TINY_1D, "seed": 3})
    assert train_seeds(cfg, tmp_path, 3, use_ray=False, progress=False) == 0
    s = json.loads((tmp_path / "seeds.json").read_text())
    assert s["seeds"] == [3, 4, 5] and len(s["per_seed"]) == 3
    goals = [p["rates"]["goal"] for p in s["per_seed"]]
    o = s["over_seeds"]["goal"]
    assert o["min"] == min(goals) and o["max"] == max(goals) and o["mean"] == pytest.approx(sum(goals) / 3)
    for p in s["per_seed"]:
        lo, hi = p["ci95"]["goal"]
        assert lo <= p["rates"]["goal"] <= hi and p["episodes"] == 30
    assert (tmp_path / "seeds.png").stat().st_size > 10_000
    assert "| **mean** |" in (tmp_path / "seeds.md").read_text()
    # different seeds really train differently (their weights are not the same file)
    w = [(tmp_path / f"seed_{k}" / "policy.safetensors").read_bytes() for k in (3, 4)]
    assert w[0] != w[1]
    # runs trained apart aggregate the same way from the command line; a missing run is one line
    assert seeds_main([str(tmp_path / "seed_3"), str(tmp_path / "seed_5"), "--out", str(tmp_path / "two")]) == 0
    two = json.loads((tmp_path / "two" / "seeds.json").read_text())
    assert two["seeds"] == [3, 5] and two["over_seeds"]["goal"]["max"] == max(goals[0], goals[2])
    capsys.readouterr()
    assert seeds_main([str(tmp_path / "nope"), "--out", str(tmp_path / "none")]) == 2
    assert "nope" in capsys.readouterr().err


def test_seeds_reevaluated_on_the_same_fresh_missions(tmp_path, tiny_overrides, capsys):
    """--evaluate N: every seed's final and best weights, raw and shielded, on one set of N missions."""
    cfg = config_mod.build("study", overrides={**tiny_overrides, "scenario": "study2d", "total_steps": 300,
                                                "prefill_steps": 100, "n_envs": 4, "eval_episodes": 10})
    assert train_seeds(cfg, tmp_path, 2, use_ray=False, progress=False) == 0
    runs = [str(tmp_path / f"seed_{k}") for k in (0, 1)]
    assert seeds_main([*runs, "--out", str(tmp_path / "ev"), "--evaluate", "12", "--scenario", "study2d",
                       "--planner", "none"]) == 0
    for stem in ("policy_raw", "policy_shield", "best_raw", "best_shield"):
        s = json.loads((tmp_path / "ev" / f"seeds_{stem}.json").read_text())
        assert s["seeds"] == [0, 1] and s["episodes_per_seed"] == 12 and s["scenario"] == "study2d"
        for p in s["per_seed"]:
            assert sum(p["rates"].values()) == pytest.approx(1.0)
    raw = json.loads((tmp_path / "ev" / "seeds_policy_raw.json").read_text())
    shield = json.loads((tmp_path / "ev" / "seeds_policy_shield.json").read_text())
    assert raw["shield"] is False and shield["shield"] is True
    # --reuse: a run found in an earlier file on the same missions is taken from it, the others are
    # flown; a file of the other driver (shielded) gives nothing; a file of other missions (another
    # episode count) is refused, naming the field
    part = {**raw, "runs": raw["runs"][:1], "per_seed": [{**raw["per_seed"][0], "marker": 1}]}
    (tmp_path / "part.json").write_text(json.dumps(part))
    (tmp_path / "other.json").write_text(json.dumps({**part, "episodes_per_seed": 13}))
    args = [*runs, "--out", str(tmp_path / "ev2"), "--evaluate", "12", "--scenario", "study2d",
            "--planner", "none", "--weights", "policy", "--reuse"]
    capsys.readouterr()
    assert seeds_main([*args, f"{tmp_path / 'part.json'},{tmp_path / 'other.json'}"]) == 2
    assert "episodes_per_seed 13 (this run: 12)" in capsys.readouterr().err
    assert seeds_main([*args, f"{tmp_path / 'part.json'}"]) == 0
    again = json.loads((tmp_path / "ev2" / "seeds_policy_raw.json").read_text())
    assert again["per_seed"][0].get("marker") == 1 and "marker" not in again["per_seed"][1]
    assert again["per_seed"][1] == raw["per_seed"][1]               # flown again: the same missions
    assert "marker" not in json.loads((tmp_path / "ev2" / "seeds_policy_shield.json").read_text())["per_seed"][0]


def test_train_seeds_cli_refuses_used_out(tmp_path, capsys):
    (tmp_path / "x").mkdir()
    (tmp_path / "x" / "episodes.csv").write_text("episode\n")
    assert train_main(["--seeds", "2", "--out", str(tmp_path / "x")]) == 2
    assert "not empty" in capsys.readouterr().err


def test_sweep_file_is_checked(tmp_path):
    f = tmp_path / "s.yaml"
    f.write_text("base: {preset: study, total_steps: 100}\nspace: {lr_actor: {uniform: [1, 2]}}\ntrails: 3\n")
    with pytest.raises(ValueError, match="trails: unknown sweep key"):
        load_spec(f)
    f.write_text("base: {preset: study, total_steps: 100}\nspace: {lr_acter: {uniform: [1, 2]}}\n")
    with pytest.raises(ValueError, match="space.lr_acter: unknown config key"):
        load_spec(f)
    f.write_text("base: {preset: study, total_steps: 100}\nspace: {tau: {normal: [0, 1]}}\n")
    with pytest.raises(ValueError, match="space.tau: expected one of"):
        load_spec(f)


def tiny_sweep_file(tmp_path, extra: str):
    """A 2-trial sweep of the 1D case (400 steps, 2 evaluations of 10 missions) plus ``extra``."""
    f = tmp_path / "tiny.yaml"
    base = {**TINY_1D, "total_steps": 400, "eval_episodes": 10}
    f.write_text(f"name: tiny\nbase: {json.dumps({'preset': 'study', **base})}\n"
                 "space:\n  lr_actor: {loguniform: [1.0e-4, 1.0e-2]}\n  actor_hidden: {choice: [[16, 16], [32]]}\n"
                 f"trials: 2\nreports: 2\neval_episodes: 10\n{extra}\n")
    return f


def test_sweep_reference_trains_the_base_config_under_the_trial_protocol(tmp_path, capsys):
    """``--reference``: the base config itself, same budget and held-out missions as a trial, no Ray."""
    f = tiny_sweep_file(tmp_path, "eval_seed: 99")
    out = tmp_path / "out"
    assert sweep_main(["--config", str(f), "--out", str(out), "--reference", "--quiet"]) == 0
    ref = json.loads((out / "tiny_reference.json").read_text())
    assert ref["lr_actor"] == 1e-3 and ref["actor_hidden"] == [16, 16]      # the base values, none sampled
    assert len(ref["evaluations"]) == 2 and ref["env_steps"] == 400 and 0.0 <= ref["goal"] <= 1.0
    assert "base config: goal" in capsys.readouterr().out


@pytest.mark.skipif(importlib.util.find_spec("ray") is None or importlib.util.find_spec("optuna") is None,
                    reason="Ray/Optuna not installed (optional extra: bash scripts/setup.sh --with-ray)")
def test_two_trial_sweep_on_local_ray_and_resume(tmp_path, capsys):
    f = tiny_sweep_file(tmp_path, "concurrent: 2")
    out = tmp_path / "out"
    try:
        assert sweep_main(["--config", str(f), "--out", str(out), "--quiet"]) == 0
        with (out / "tiny_trials.csv").open() as fh:
            rows = list(csv.DictReader(fh))
        assert len(rows) == 2 and all(0.0 <= float(r["goal"]) <= 1.0 for r in rows)
        assert {json.loads(r["actor_hidden"]) == [16, 16] or json.loads(r["actor_hidden"]) == [32] for r in rows} == {True}
        best = config_mod.build(file=out / "tiny_best.yaml")       # the best config trains as it is
        assert best.scenario == "study1d" and best.total_steps == 400 and best.threads == 1
        assert (out / "tiny.png").stat().st_size > 10_000
        capsys.readouterr()
        # running it again resumes the finished experiment: no new trials
        assert sweep_main(["--config", str(f), "--out", str(out), "--quiet"]) == 0
        assert "resuming" in capsys.readouterr().err
        with (out / "tiny_trials.csv").open() as fh:
            assert len(list(csv.DictReader(fh))) == 2
        # --results: the table from the experiment as it stands, no trial run
        (out / "tiny_trials.csv").unlink()
        assert sweep_main(["--config", str(f), "--out", str(out), "--results", "--quiet"]) == 0
        with (out / "tiny_trials.csv").open() as fh:
            assert len(list(csv.DictReader(fh))) == 2
    finally:
        import ray
        ray.shutdown()
