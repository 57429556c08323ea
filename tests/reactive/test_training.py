"""Training: learns the 1D case, is deterministic under a seed, resumes; config overrides."""
import numpy as np
import pytest
from safetensors.torch import load_file

from cage_reactive_ddpg import config as config_mod
from cage_reactive_ddpg.study1d import evaluate_1d
from cage_reactive_ddpg.train import Trainer


class RandomPolicy:
    def __init__(self, seed):
        self.rng = np.random.default_rng(seed)

    def act(self, obs):
        return self.rng.uniform(-1, 1, (1,))


def _train(tmp_path, name, overrides, preset="study"):
    cfg = config_mod.build(preset, overrides=overrides)
    tr = Trainer(cfg, tmp_path / name, progress=False)
    final = tr.run()
    return tr, final


def test_tiny_training_beats_random_on_1d(tmp_path, tiny_overrides):
    over = {**tiny_overrides, "scenario": "study1d", "total_steps": 3000, "n_envs": 4, "prefill_steps": 500,
            "lr_actor": 1e-3, "lr_critic": 1e-3, "tau": 0.01, "gamma": 0.5, "noise": "gaussian",
            "noise_std": 0.3, "eval_episodes": 100}
    _, final = _train(tmp_path, "1d", over)
    rand = evaluate_1d(RandomPolicy(0), 100, 987_654)
    assert final["mean_reward"] > rand["mean_reward"] + 1.0
    assert final["rates"]["goal"] > rand["rates"]["goal"] + 0.3
    assert final["mean_steps"] < rand["mean_steps"]


def test_same_seed_gives_identical_weights(tmp_path, tiny_overrides):
    over = {**tiny_overrides, "scenario": "study2d", "total_steps": 1200, "n_envs": 4, "prefill_steps": 400,
            "n_step": 3, "twin_critic": True, "policy_delay": 2, "target_noise": 0.2, "eval_episodes": 5,
            "obs_norm": True}
    a, _ = _train(tmp_path, "a", over)
    b, _ = _train(tmp_path, "b", over)
    wa, wb = load_file(str(a.out / "policy.safetensors")), load_file(str(b.out / "policy.safetensors"))
    assert wa.keys() == wb.keys()
    for k in wa:
        assert (wa[k] == wb[k]).all(), k
    c, _ = _train(tmp_path, "c", {**over, "seed": 1})
    wc = load_file(str(c.out / "policy.safetensors"))
    assert any((wa[k] != wc[k]).any() for k in wa)
    assert (a.out / "episodes.csv").is_file() and (a.out / "learning_curve.png").is_file()


def test_resume_continues_from_checkpoint(tmp_path, tiny_overrides):
    over = {**tiny_overrides, "scenario": "study2d", "total_steps": 600, "n_envs": 4, "prefill_steps": 200,
            "eval_episodes": 5}
    a, _ = _train(tmp_path, "a", over)
    cfg = config_mod.build("study", overrides={**over, "total_steps": 1000})
    tr = Trainer(cfg, tmp_path / "a", progress=False)
    tr.load_checkpoint(a.out / "checkpoint.pt")
    assert tr.step == 600 and tr.buffer.size == a.buffer.size and tr.agent.n_updates == a.agent.n_updates
    tr.run()
    assert tr.step == 1000 and tr.agent.n_updates > a.agent.n_updates


def test_config_presets_files_and_overrides(tmp_path):
    cfg = config_mod.build("study")
    assert (cfg.actor_hidden, cfg.lr_actor, cfg.lr_critic, cfg.gamma, cfg.tau, cfg.batch_size, cfg.buffer_size) == \
        ((400, 300), 1e-4, 1e-3, 0.99, 0.001, 64, 150_000)
    assert config_mod.build("study_extra_layer").critic_hidden == (400, 300, 200)
    f = tmp_path / "c.yaml"
    f.write_text("preset: study_low_lr\nbatch_size: 128\nreward:\n  progress_weight: 0.5\n")
    cfg = config_mod.build(file=f, overrides=["gamma=0.95", "actor_hidden=[64, 64]", "reward.goal=10"])
    assert cfg.lr_critic == 1e-4 and cfg.batch_size == 128 and cfg.gamma == 0.95
    assert cfg.actor_hidden == (64, 64) and cfg.reward == {"progress_weight": 0.5, "goal": 10.0}
    assert cfg.env_config().reward.goal == 10.0
    with pytest.raises(ValueError, match="gamm: unknown config key"):
        config_mod.build(overrides=["gamm=0.9"])
    with pytest.raises(ValueError, match="reward: unknown field"):
        config_mod.build(overrides={"reward.golden": 1})
    with pytest.raises(ValueError, match="batch_size: expected int"):
        config_mod.build(overrides=["batch_size=big"])
