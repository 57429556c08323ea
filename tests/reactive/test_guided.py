"""Expert guidance: the baseline's actions are stored with every transition, demonstration episodes
follow it, and the Q-filtered behaviour-cloning term pulls the actor towards it (and only where the
critic agrees)."""
import csv

import numpy as np
import pytest
import torch
from cage_sim.controller import ArcController

from cage_reactive_ddpg import config as config_mod
from cage_reactive_ddpg.agent import DDPGAgent, NearReturns
from cage_reactive_ddpg.buffer import NStepFolder, ReplayBuffer
from cage_reactive_ddpg.train import Trainer


def test_nstep_folding_keeps_the_first_observations_expert_label():
    folder, buf = NStepFolder(1, 3, 0.9), ReplayBuffer(10, 2)
    for k in range(4):
        for tr in folder.push(0, np.full(2, k), [0.0], 1.0, np.full(2, k + 1), False, k == 3, [0.1 * k]):
            buf.add(*tr)
    assert buf.size == 4
    assert np.allclose(buf.obs[:4, 0], [0, 1, 2, 3]) and np.allclose(buf.expert[:4, 0], [0.0, 0.1, 0.2, 0.3])
    buf.add(np.zeros(2), [0.0], 0.0, np.zeros(2), 1.0)                      # unlabelled: NaN
    assert np.isnan(buf.expert[4]).all()
    restored = ReplayBuffer(10, 2)
    restored.load_state(buf.state())
    assert np.array_equal(restored.expert[:5], buf.expert[:5], equal_nan=True)


def _batch(n, expert_value, seed=0):
    rng = np.random.default_rng(seed)
    buf = ReplayBuffer(n, 3)
    buf.add(rng.uniform(-1, 1, (n, 3)), rng.uniform(-1, 1, (n, 1)), rng.uniform(-1, 1, n),
            rng.uniform(-1, 1, (n, 3)), np.full(n, 0.9), np.full((n, 1), expert_value))
    return buf


@pytest.mark.parametrize("weight, moves", [(0.0, False), (5.0, True)])
def test_cloning_term_pulls_the_actor_to_the_expert(weight, moves, tiny_overrides):
    cfg = config_mod.build("fast", overrides={**tiny_overrides, "policy_delay": 1, "q_filter": False,
                                              "expert": "baseline", "bc_weight": max(weight, 1.0)})
    torch.manual_seed(0)
    agent, buf, rng = DDPGAgent(cfg, 3), _batch(256, 0.7), np.random.default_rng(1)
    obs = torch.from_numpy(buf.obs[:256])
    with torch.no_grad():
        before = float((agent.actor(obs) - 0.7).abs().mean())
    for _ in range(800):
        info = agent.update(buf.sample(rng, 64), weight)
    with torch.no_grad():
        after = float((agent.actor(obs) - 0.7).abs().mean())
    assert (after < 0.5 * before) == moves, (before, after)
    assert ("bc_loss" in info) == moves


@pytest.mark.parametrize("near_weight, moves", [(0.0, False), (5.0, True)])
def test_near_return_cloning_pulls_only_where_a_return_is_near(near_weight, moves, tiny_overrides):
    """The unfiltered term acts on the rows whose first column (a range / max_range) is near, and
    only there: with no other cloning (bc weight 0 this update) the far rows keep their actions."""
    cfg = config_mod.build("fast", overrides={**tiny_overrides, "policy_delay": 1, "expert": "baseline",
                                              "bc_weight": 1.0, "near_bc_weight": near_weight})
    torch.manual_seed(0)
    buf = _batch(256, 0.7)
    buf.obs[:256, 0] = np.where(np.arange(256) % 2 == 0, 0.05, 0.9)      # even rows: a return 1 m off
    near = NearReturns(cols=1, threshold=3.0 / 20.0)
    agent, rng = DDPGAgent(cfg, 3, near=near), np.random.default_rng(1)
    obs = torch.from_numpy(buf.obs[:256])
    assert near(obs).tolist() == [i % 2 == 0 for i in range(256)]
    for _ in range(800):
        info = agent.update(buf.sample(rng, 64), 0.0)
    with torch.no_grad():
        err = (agent.actor(obs)[:, 0] - 0.7).abs()
    near_err, far_err = float(err[0::2].mean()), float(err[1::2].mean())
    assert (near_err < 0.5 * far_err) == moves, (near_err, far_err)
    assert ("near_share" in info) == moves
    if moves:
        assert 0.2 < float(info["near_share"]) < 0.8


def test_near_returns_counts_the_scan_and_the_memory_of_a_layout():
    from cage_sim.observation import ObservationLayoutV2
    from cage_sim.sonar import make_sonar
    layout = ObservationLayoutV2.for_sonar(make_sonar("study"), velocity=True, memory_bins=8)
    near = NearReturns.for_layout(layout, 3.0)
    assert near.cols == 72 + 8 and near.threshold == pytest.approx(3.0 / layout.max_range)
    far = np.ones((2, layout.size + 1), np.float32)        # + the residual's base action, last
    far[1, 72 + 3] = 2.0 / layout.max_range                # a remembered return 2 m off
    far[:, -1] = -1.0                                      # never read as a range
    assert near(torch.from_numpy(far)).tolist() == [False, True]
    with pytest.raises(ValueError, match="near_bc_weight"):
        config_mod.build(overrides={"expert": "baseline", "near_bc_weight": -1.0})


def test_q_filter_keeps_only_expert_actions_the_critic_rates_higher(tiny_overrides):
    cfg = config_mod.build("fast", overrides={**tiny_overrides, "policy_delay": 1, "expert": "baseline",
                                              "bc_weight": 1.0, "lr_critic": 0.0})   # the critic stays as judged
    torch.manual_seed(0)
    agent, buf = DDPGAgent(cfg, 3), _batch(64, 0.7)
    b = buf.sample(np.random.default_rng(0), 64)
    obs, exp = torch.from_numpy(b.obs), torch.from_numpy(b.expert)
    with torch.no_grad():
        pi = agent.actor(obs)
        want = (agent.critic(obs, exp, members=1)[0] >= agent.critic(obs, pi, members=1)[0]).float().mean()
    info = agent.update(b, 1.0)
    assert 0.0 < float(want) < 1.0                 # the random critic disagrees on some rows
    assert float(info["bc_kept"]) == pytest.approx(float(want))


def test_guided_training_labels_every_transition_and_flies_demonstrations(tmp_path, tiny_overrides):
    over = {**tiny_overrides, "scenario": "study2d", "motion": "continuous", "total_steps": 800, "n_envs": 4,
            "prefill_steps": 200, "eval_episodes": 5, "velocity": True, "observation": "v2",
            "expert": "baseline", "expert_fraction": 1.0, "bc_weight": 1.0, "noise_std": 0.0,
            "noise_final_std": 0.0}
    tr = Trainer(config_mod.build("fast", overrides=over), tmp_path / "g", progress=False)
    tr.run()
    n = tr.buffer.size
    assert n > 0 and np.isfinite(tr.buffer.expert[:n]).all()
    # every episode a demonstration, flown without noise: the stored actions are the expert's own
    assert np.allclose(tr.buffer.act[:n], tr.buffer.expert[:n], atol=1e-6)
    ctrl = ArcController(tr.env_cfg.layout, tr.env_cfg.vehicle)
    assert np.allclose(ctrl.act(tr.buffer.obs[:50]), tr.buffer.expert[:50], atol=1e-6)
    with (tr.out / "episodes.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert rows and all(r["demo"] == "1" for r in rows)


def test_guidance_without_an_expert_is_refused():
    with pytest.raises(ValueError, match="need an expert"):
        config_mod.build(overrides={"bc_weight": 1.0})
    with pytest.raises(ValueError, match="expert: must be one of"):
        config_mod.build(overrides={"expert": "oracle"})
