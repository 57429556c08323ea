"""Ensemble policy files: several residual actors packed into one file, flown as the mean action."""
from __future__ import annotations

import json

import numpy as np
import pytest
import torch
from cage_sim.controller import ArcController
from cage_sim.mission import EnvConfig
from cage_sim.scenarios import draw_scenario

from cage_reactive_ddpg import ensemble
from cage_reactive_ddpg.evaluate import run_missions
from cage_reactive_ddpg.inference import MeanActor
from cage_reactive_ddpg.networks import Actor
from cage_reactive_ddpg.policy import PolicyLoadError, load_policy, save_policy

ENV = EnvConfig(sonar="study", observation="v2", velocity=True, memory_bins=72)
CFG = {"sensor": "study", "observation": "v2", "velocity": True, "memory_bins": 72}


def _member(path, seed, zero=False, layout=ENV.layout, residual=True, cfg=None):
    torch.manual_seed(seed)
    a = Actor(layout.size + residual, (32, 32), residual=residual)
    with torch.no_grad():
        if zero:
            a.net[-1].weight.zero_()
            a.net[-1].bias.zero_()
        else:
            a.net[-1].weight.mul_(300.0)        # far from zero, both signs: members disagree
    save_policy(path, a, {"config": {**CFG, "seed": seed, **(cfg or {})},
                          "evaluation": {"episodes": 10, "seed": seed}}, layout)
    return path


def test_an_ensemble_flies_the_mean_of_its_members_actions(tmp_path):
    files = [_member(tmp_path / f"m{s}.safetensors", s) for s in range(3)]
    assert ensemble.main([str(f) for f in files] + ["--out", str(tmp_path / "ens")]) == 0
    pol = load_policy(tmp_path / "ens.safetensors")
    assert isinstance(pol.actor, MeanActor) and len(pol.actor.members) == 3
    members = [load_policy(f) for f in files]
    rng = np.random.default_rng(3)
    obs = rng.uniform(0, 1, (40, ENV.layout.size)).astype(np.float32)
    base = rng.uniform(-1, 1, (40, 1)).astype(np.float32)
    each = np.stack([m.act_residual(obs, base) for m in members])
    got = pol.act_residual(obs, base)
    assert got.shape == (40, 1) and got.dtype == np.float32
    assert np.allclose(got, each.mean(axis=0), atol=1e-7)
    assert np.abs(each - got).max() > 0.1                    # the members do disagree
    assert pol.act_residual(obs[0], base[0]).shape == (1,)
    meta = json.loads((tmp_path / "ens.json").read_text())
    assert meta["network"]["ensemble"] == 3 and "evaluation" not in meta
    rec = meta["ensemble"]["members"]
    assert [r["seed"] for r in rec] == [0, 1, 2] and rec[1]["config_differences"] == {"seed": 1}
    assert rec[2]["evaluation"] == {"episodes": 10, "seed": 2}
    assert rec[0]["sha256"] == ensemble.sha256(files[0])


def test_an_ensemble_of_zero_residuals_flies_the_flown_baseline(tmp_path):
    """Through the evaluator's path with perception (current, fleeing schools, small obstacles)."""
    files = [_member(tmp_path / f"z{s}.safetensors", s, zero=True) for s in range(2)]
    ensemble.pack(files, tmp_path / "ens.safetensors")
    scs = [draw_scenario("cage?current=0.4&schools=2&obstacles=small", s) for s in range(4)]
    base = run_missions(ArcController(ENV.layout, ENV.vehicle), scs, ENV)
    ens = run_missions(load_policy(tmp_path / "ens.safetensors"), scs, ENV)
    assert [(r.outcome, r.steps) for r in ens] == [(r.outcome, r.steps) for r in base]


def test_members_that_do_not_fit_together_are_refused(tmp_path, capsys):
    a = _member(tmp_path / "a.safetensors", 0)
    plain = _member(tmp_path / "p.safetensors", 1, residual=False)
    other_memory = _member(tmp_path / "o.safetensors", 2, layout=EnvConfig(
        sonar="study", observation="v2", velocity=True, memory_bins=36).layout, cfg={"memory_bins": 36})
    with pytest.raises(ValueError, match="network"):
        ensemble.pack([a, plain], tmp_path / "x")
    with pytest.raises(ValueError, match="observation_layout"):
        ensemble.pack([a, other_memory], tmp_path / "x")
    with pytest.raises(ValueError, match="at least 2"):
        ensemble.pack([a], tmp_path / "x")
    assert ensemble.main([str(a), str(tmp_path / "missing.safetensors"), "--out", str(tmp_path / "x")]) == 2
    assert "not found" in capsys.readouterr().err
    assert not (tmp_path / "x.safetensors").exists()
    ensemble.pack([a, a], tmp_path / "e2")
    with pytest.raises(ValueError, match="itself an ensemble"):
        ensemble.pack([tmp_path / "e2.safetensors", a], tmp_path / "x")


def test_an_ensemble_file_that_lies_about_its_members_is_refused(tmp_path):
    files = [_member(tmp_path / f"m{s}.safetensors", s) for s in range(2)]
    ensemble.pack(files, tmp_path / "ens")
    meta = json.loads((tmp_path / "ens.json").read_text())
    for count, match in ((3, "missing tensors"), (1, "member count"), ("2", "member count")):
        meta["network"]["ensemble"] = count
        (tmp_path / "ens.json").write_text(json.dumps(meta))
        with pytest.raises(PolicyLoadError, match=match):
            load_policy(tmp_path / "ens.safetensors")
