"""DAgger distillation: the labels are the shielded driver's decisions, the student learns them, and
a run writes a policy every loader runs."""
import csv
import json

import numpy as np
import pytest
import torch
from cage_sim.controller import ArcController
from cage_sim.shield import SafetyShield

from cage_reactive_ddpg.dagger import KINDS, Labelled, collect, evaluate_student
from cage_reactive_ddpg.distill import Dataset, DistillConfig, Student, build_config, main, widened
from cage_reactive_ddpg.evaluate import replan_planner, run_missions, summarize
from cage_reactive_ddpg.inference import read_state
from cage_reactive_ddpg.missions import episode_scenarios, waypoint_fn
from cage_reactive_ddpg.policy import env_config_for, load_policy, shipped_path

SPEC = "sea:current=0.5,obstacles=small,goal=near_net,schools=2"
TEACHER = str(shipped_path())


def _scenarios(n, seed):
    return episode_scenarios(SPEC, n, seed, waypoint_fn("rrt"))


def test_teacher_flown_missions_end_as_the_shielded_driver_in_evaluate():
    """With no student, every decision is the shielded driver's: the missions end exactly as
    ``evaluate`` ends them (same code path), and one label is stored per decision flown."""
    data = collect(TEACHER, None, SPEC, 11, 0, 6, beta=1.0, noise_std=0.0)
    pol = load_policy(TEACHER)
    env = env_config_for(pol.metadata)
    res = run_missions(SafetyShield(pol, ArcController(pol.layout)), _scenarios(6, 11), env,
                       replan=replan_planner(waypoint_fn("rrt"), True))
    assert data.outcomes == {k: v for k, v in summarize(res)["counts"].items() if v}
    assert len(data.label) == len(data.obs) == sum(r.steps for r in res)
    assert data.obs.shape[1] == pol.layout.size and np.all(np.abs(data.label) <= 1.0)
    # where the label is not the policy's own action, the shield (or one of its guards) chose it
    assert 0 < data.overridden.sum() < len(data.label)
    assert np.all(data.kind[data.overridden] != 0) and data.counts()["safety"] > 0
    assert sum(data.counts().values()) == len(data.label)
    assert np.allclose(data.own, pol.act(data.obs)[:, 0], atol=1e-6)


def test_a_student_flies_alone_at_beta_zero_and_is_still_labelled():
    """beta 0, no noise, the student = the raw teacher: the flown missions are the raw policy's,
    while the labels are still the shielded driver's along that track."""
    state = read_state(TEACHER)
    data = collect(TEACHER, state, SPEC, 11, 0, 6, beta=0.0, noise_std=0.0)
    raw = evaluate_student(TEACHER, state, SPEC, 11, 0, 6)
    assert data.outcomes == {k: v for k, v in raw.items() if v}
    pol = load_policy(TEACHER)
    env = env_config_for(pol.metadata)
    res = run_missions(pol, _scenarios(6, 11), env, replan=replan_planner(waypoint_fn("rrt"), True))
    assert len(data.label) == sum(r.steps for r in res)


def test_student_from_the_teacher_starts_as_the_teacher_and_fits_labels():
    state = read_state(TEACHER)
    pol = load_policy(TEACHER)
    s = Student(pol.layout.size, pol.actor.hidden, 0, 1, state)
    obs = collect(TEACHER, None, SPEC, 12, 0, 2, 1.0, 0.0).obs
    with torch.no_grad():
        assert np.allclose(s.actor(torch.from_numpy(obs)).numpy()[:, 0], pol.act(obs)[:, 0], atol=1e-6)
    target = -pol.act(obs)[:, 0]                     # the opposite turn everywhere: far from the start
    w = np.ones(len(obs), np.float32)
    first = s.fit(obs, target, w, 1, 64, 1e-3)
    last = s.fit(obs, target, w, 30, 64, 1e-3)
    assert last < 0.25 * first, (first, last)


def test_widened_teacher_computes_the_same_function_and_cannot_shrink():
    state = read_state(TEACHER)
    wide = widened(state, (256, 192), np.random.default_rng(0))
    assert wide["net.0.weight"].shape == (256, 148) and wide["net.2.weight"].shape == (192, 256)
    obs = np.random.default_rng(1).uniform(0, 1, (64, 148)).astype(np.float32)
    s = Student(148, (256, 192), 0, 1, wide)
    with torch.no_grad():
        assert np.allclose(s.actor(torch.from_numpy(obs)).numpy(), load_policy(TEACHER).act(obs), atol=1e-6)
    with pytest.raises(ValueError, match="cannot grow"):
        widened(state, (64, 128), np.random.default_rng(0))


def test_labels_of_kinds_not_imitated_fall_back_to_the_teachers_own_action():
    kinds = np.array([KINDS.index(k) for k in KINDS], dtype=np.int8)
    own = np.zeros(len(kinds), np.float32)
    part = Labelled(np.zeros((len(kinds), 3), np.float32), np.full(len(kinds), 0.8, np.float32), own, kinds)
    data = Dataset([part])
    _, target, w = data.arrays(3.0, ["safety", "open_water"])
    assert np.allclose(target, [0.8, 0.8, 0.0, 0.0, 0.8]) and w.tolist() == [3.0, 3.0, 1.0, 1.0, 3.0]


def test_a_short_run_writes_a_policy_the_loaders_run(tmp_path):
    out = tmp_path / "run"
    assert main(["--out", str(out), "--quiet", "--set", "iterations=2", "--set", "missions=6",
                 "--set", "eval_episodes=4", "--set", "epochs=1", "--set", "workers=1",
                 "--set", f"scenario={SPEC}", "--set", "eval_scenario=cage"]) == 0
    pol = load_policy(out / "policy.safetensors", profile="study")
    meta = pol.metadata
    assert meta["training"]["method"].startswith("DAgger") and len(meta["distillation"]["iterations"]) == 2
    assert meta["evaluation"]["episodes"] == 4 and meta["observation_layout"] == load_policy(TEACHER).metadata["observation_layout"]
    assert env_config_for(meta) == env_config_for(load_policy(TEACHER).metadata)
    rows = list(csv.DictReader((out / "iterations.csv").open()))
    assert [int(r["iteration"]) for r in rows] == [0, 1] and float(rows[0]["beta"]) == 1.0
    assert int(rows[1]["dataset"]) == int(rows[0]["states"]) + int(rows[1]["states"])
    assert (out / "distill_curve.png").stat().st_size > 1000 and (out / "best.safetensors").is_file()
    assert json.loads((out / "policy.json").read_text())["config"]["sensor"] == "study"


@pytest.mark.parametrize("args, message", [
    (["--set", "init=copy"], "init: expected one of"),
    (["--set", "iterations=0"], "iterations: must be >= 1"),
    (["--set", "beta=1.5"], "beta: must be in [0, 1]"),
    (["--set", "imitate=safety,stall"], "imitate: unknown label kind"),
    (["--set", "itterations=3"], "itterations: unknown config key"),
    (["--teacher", "nope.safetensors"], "policy weights file not found"),
])
def test_bad_settings_are_one_line(tmp_path, capsys, args, message):
    assert main(["--out", str(tmp_path / "x"), *args]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err


def test_a_used_out_is_refused(tmp_path, capsys):
    (tmp_path / "keep.txt").write_text("x")
    assert main(["--out", str(tmp_path)]) == 2
    assert "is not empty" in capsys.readouterr().err


def test_config_file_and_overrides(tmp_path):
    f = tmp_path / "d.yaml"
    f.write_text("iterations: 3\nhidden: [64, 32]\nlr: 5e-4\n")
    cfg = build_config(str(f), ["missions=10"])
    assert (cfg.iterations, cfg.hidden, cfg.lr, cfg.missions) == (3, (64, 32), 5e-4, 10)
    assert DistillConfig().beta_at(0) == 1.0 and DistillConfig(beta=0.5, beta_decay=0.5).beta_at(3) == 0.125
