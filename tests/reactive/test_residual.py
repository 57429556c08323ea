"""Residual policies: the actor moves the flown baseline's action (``networks.residual_action``).

What must hold: a zero residual is the baseline exactly, in the evaluator's batched path with the
vehicle's perception (drift, moving schools, final approach); the torch and NumPy actors compute
the same action; the policy file says it is residual and names the controller it moves, and a
file for another controller or with the wrong input size is refused; training stores the flown
baseline's action as the actor's last input of every transition, its state and its next state.
"""
import json

import numpy as np
import pytest
import torch
from cage_sim.controller import ArcController
from cage_sim.mission import EnvConfig
from cage_sim.scenarios import draw_scenario

from cage_reactive_ddpg import config as config_mod
from cage_reactive_ddpg.evaluate import run_missions
from cage_reactive_ddpg.inference import NumpyActor, residual_action
from cage_reactive_ddpg.networks import Actor
from cage_reactive_ddpg.policy import PolicyLoadError, load_policy, save_policy
from cage_reactive_ddpg.train import Trainer

ENV = EnvConfig(sonar="study", observation="v2", velocity=True, memory_bins=72)


def test_residual_action_starts_at_the_base_and_reaches_both_ends():
    base = np.array([-1.0, -0.4, 0.0, 0.7, 1.0])
    assert np.array_equal(residual_action(base, np.zeros(5)), base)
    assert np.allclose(residual_action(base, np.ones(5)), 1.0)
    assert np.allclose(residual_action(base, -np.ones(5)), -1.0)
    r = np.random.default_rng(0).uniform(-1, 1, (1000, 5))
    out = residual_action(base, r)
    assert out.min() >= -1.0 and out.max() <= 1.0
    # a full turn (base = 1) can still be pulled back: the slope towards -1 is 2, not 0 (a clip's)
    b = torch.ones(1)
    x = torch.full((1,), -0.1, requires_grad=True)
    residual_action(b, x).sum().backward()
    assert float(x.grad) == pytest.approx(2.0)


def _actor(obs_dim, zero=False, seed=0):
    torch.manual_seed(seed)
    a = Actor(obs_dim, (32, 32), residual=True)
    if zero:
        with torch.no_grad():
            a.net[-1].weight.zero_()
            a.net[-1].bias.zero_()
    else:
        with torch.no_grad():
            a.net[-1].weight.mul_(300.0)        # a residual far from zero, both signs
    return a


def test_torch_and_numpy_residual_actors_agree():
    a = _actor(ENV.layout.size + 1)
    rng = np.random.default_rng(1)
    x = rng.uniform(-1, 1, (200, ENV.layout.size + 1)).astype(np.float32)
    with torch.no_grad():
        want = a(torch.from_numpy(x)).numpy()
    got = NumpyActor({k: v.numpy() for k, v in a.state_dict().items()}, residual=True)(x)
    assert np.abs(got - want).max() < 1e-6
    assert np.abs(want - x[:, -1:]).max() > 0.1           # the residual moved the base


def test_residual_policy_file_says_so_and_is_refused_for_another_controller(tmp_path):
    a = _actor(ENV.layout.size + 1)
    save_policy(tmp_path / "r.safetensors", a, {"config": {"sensor": "study", "observation": "v2",
                                                            "velocity": True, "memory_bins": 72}}, ENV.layout)
    meta = json.loads((tmp_path / "r.json").read_text())
    assert meta["network"]["residual"] is True and meta["network"]["obs_dim"] == ENV.layout.size + 1
    assert meta["residual_base"]["params"] == ArcController(ENV.layout).tunables()
    pol = load_policy(tmp_path / "r.safetensors")
    assert isinstance(pol.residual_base, ArcController)
    obs = np.random.default_rng(2).uniform(0, 1, (5, ENV.layout.size)).astype(np.float32)
    # act() alone: the base is the controller on the observation (perception off)
    assert np.array_equal(pol.act(obs), pol.act_residual(obs, pol.residual_base.act(obs)))
    meta["residual_base"]["params"]["min_clearance"] = 0.9
    (tmp_path / "r.json").write_text(json.dumps(meta))
    with pytest.raises(PolicyLoadError, match="min_clearance: file has 0.9, this build uses 1.1"):
        load_policy(tmp_path / "r.safetensors")
    meta["residual_base"]["params"]["min_clearance"] = 1.1
    meta["residual_base"]["params"]["pursuit"] = "yes"
    (tmp_path / "r.json").write_text(json.dumps(meta))
    with pytest.raises(PolicyLoadError, match="pursuit is 'yes', expected true or false"):
        load_policy(tmp_path / "r.safetensors")
    meta["residual_base"]["params"]["pursuit"] = False
    meta["residual_base"]["params"]["handover_tail"] = 2.5
    (tmp_path / "r.json").write_text(json.dumps(meta))
    with pytest.raises(PolicyLoadError, match="handover_tail is 2.5, expected an integer"):
        load_policy(tmp_path / "r.safetensors")
    meta["residual_base"]["params"]["handover_tail"] = 2
    meta["residual_base"]["params"]["handover"] = -1
    (tmp_path / "r.json").write_text(json.dumps(meta))
    with pytest.raises(PolicyLoadError, match="handover and handover_tail must be >= 0, got -1 and 2"):
        load_policy(tmp_path / "r.safetensors")
    meta["residual_base"]["params"]["handover"] = 0.0
    meta["network"]["residual"] = False
    (tmp_path / "r.json").write_text(json.dumps(meta))
    with pytest.raises(PolicyLoadError, match="obs_dim"):
        load_policy(tmp_path / "r.safetensors")


def test_the_base_controller_is_the_one_recorded_and_the_shield_falls_back_to_it(tmp_path):
    """A policy trained on the pursuit controller records it, loads with it, and its shield's
    fallback is that controller (one decision shared); a file written before ``pursuit`` existed
    (no such key) loads with it off, as it was trained."""
    from cage_reactive_ddpg.evaluate import load_driver
    from cage_sim.driver import fallback_for, same_decisions
    a = _actor(ENV.layout.size + 1)
    cfg = {"config": {"sensor": "study", "observation": "v2", "velocity": True, "memory_bins": 72}}
    base = ArcController(ENV.layout, pursuit=True, handover=2.0, handover_tail=5)
    save_policy(tmp_path / "p.safetensors", a, cfg, ENV.layout, base=base)
    meta = json.loads((tmp_path / "p.json").read_text())
    assert meta["residual_base"]["params"]["pursuit"] is True
    assert (meta["residual_base"]["params"]["handover"], meta["residual_base"]["params"]["handover_tail"]) == (2.0, 5)
    pol = load_policy(tmp_path / "p.safetensors")
    assert pol.residual_base.tunables() == base.tunables()
    shield, _, _ = load_driver(str(tmp_path / "p.safetensors"), shield=True)
    assert shield.fallback.tunables() == base.tunables() and same_decisions(shield.fallback, shield.policy.residual_base)
    for k in ("pursuit", "handover", "handover_tail"):
        del meta["residual_base"]["params"][k]
    (tmp_path / "p.json").write_text(json.dumps(meta))
    old = load_policy(tmp_path / "p.safetensors")
    assert old.residual_base.pursuit is False and fallback_for(old, old.layout).pursuit is False
    assert old.residual_base.handover == 0.0 and fallback_for(old, old.layout).handover == 0.0
    assert fallback_for(ArcController(ENV.layout, pursuit=True), ENV.layout).pursuit is False   # not residual


def test_the_memory_the_base_counted_is_recorded_and_loaded(tmp_path):
    """A base trained reading the cleared memory (``expert_remembered: cleared``) records it and loads
    with it, so raw flights perceive as in training; absent (files before session 55): every
    remembered return; an unknown value is refused, naming the field."""
    fls = EnvConfig(sonar="fls", velocity=True, memory_bins=72)
    cfg = {"config": {"sensor": "fls", "observation": "v2", "velocity": True, "memory_bins": 72}}
    save_policy(tmp_path / "c.safetensors", _actor(fls.layout.size + 1), cfg, fls.layout,
                base=ArcController(fls.layout, remembered="cleared"))
    meta = json.loads((tmp_path / "c.json").read_text())
    assert meta["residual_base"]["remembered"] == "cleared"
    assert load_policy(tmp_path / "c.safetensors").residual_base.remembered == "cleared"
    del meta["residual_base"]["remembered"]
    (tmp_path / "c.json").write_text(json.dumps(meta))
    assert load_policy(tmp_path / "c.safetensors").residual_base.remembered == "all"
    meta["residual_base"]["remembered"] = "some"
    (tmp_path / "c.json").write_text(json.dumps(meta))
    with pytest.raises(PolicyLoadError, match="residual_base.remembered is 'some'"):
        load_policy(tmp_path / "c.safetensors")


def test_a_zero_residual_flies_the_flown_baseline(tmp_path):
    """Same missions (current, fleeing schools, small obstacles), the evaluator's path with
    perception: the residual policy with a zero residual ends every mission as the baseline does,
    after the same number of decisions; a trained-looking residual does not."""
    save_policy(tmp_path / "z.safetensors", _actor(ENV.layout.size + 1, zero=True), {}, ENV.layout)
    save_policy(tmp_path / "n.safetensors", _actor(ENV.layout.size + 1), {}, ENV.layout)
    scs = [draw_scenario("cage?current=0.4&schools=2&obstacles=small", s) for s in range(6)]
    base = run_missions(ArcController(ENV.layout, ENV.vehicle), scs, ENV)
    zero = run_missions(load_policy(tmp_path / "z.safetensors"), scs, ENV)
    noisy = run_missions(load_policy(tmp_path / "n.safetensors"), scs, ENV)
    assert [(r.outcome, r.steps) for r in zero] == [(r.outcome, r.steps) for r in base]
    # ... and perception matters on these missions: the controller on the observation alone differs
    blind = run_missions(ArcController(ENV.layout, ENV.vehicle), scs, ENV, perception=False)
    assert [r.steps for r in blind] != [r.steps for r in base]
    assert [r.steps for r in noisy] != [r.steps for r in base]


def test_residual_training_feeds_the_flown_baselines_action(tmp_path, tiny_overrides):
    over = {**tiny_overrides, "scenario": "cage?current=0.3&schools=2", "motion": "continuous",
            "planner": "rrt", "total_steps": 600, "n_envs": 4, "prefill_steps": 200, "eval_episodes": 4,
            "velocity": True, "observation": "v2", "memory_bins": 72, "expert": "flown", "residual": True,
            "bc_weight": 1.0, "expert_pursuit": True, "expert_handover": 2.0, "expert_handover_tail": 4}
    tr = Trainer(config_mod.build("fast", overrides=over), tmp_path / "r", progress=False)
    tr.run()
    n = tr.buffer.size
    assert n > 0 and tr.buffer.obs.shape[1] == ENV.layout.size + 1
    # the actor's last input is the expert's label of that very observation
    assert np.array_equal(tr.buffer.obs[:n, -1:], tr.buffer.expert[:n])
    assert np.isfinite(tr.buffer.next_obs[:n, -1]).all()
    pol = load_policy(tmp_path / "r" / "policy.safetensors")
    assert pol.residual_base is not None and pol.metadata["config"]["expert"] == "flown"
    assert tr.expert.pursuit and pol.residual_base.pursuit       # the base it was trained on
    assert (tr.expert.handover, tr.expert.handover_tail) == (pol.residual_base.handover, pol.residual_base.handover_tail) == (2.0, 4)


def test_a_residual_needs_the_flown_expert():
    with pytest.raises(ValueError, match="residual: needs expert: flown"):
        config_mod.build(overrides={"residual": True, "expert": "baseline"})
    with pytest.raises(ValueError, match="expert_pursuit / expert_handover: need an expert"):
        config_mod.build(overrides={"expert_pursuit": True})
    with pytest.raises(ValueError, match="expert_pursuit / expert_handover: need an expert"):
        config_mod.build(overrides={"expert_handover": 2.0})
    with pytest.raises(ValueError, match="expert_handover: must be >= 0 m"):
        config_mod.build(overrides={"expert": "flown", "expert_handover": -1.0})
    with pytest.raises(ValueError, match="expert_handover_tail: 0-9 decisions"):
        config_mod.build(overrides={"expert": "flown", "expert_handover": 2.0, "expert_handover_tail": 10})
