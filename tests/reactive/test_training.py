"""Training: learns the 1D case, is deterministic under a seed, resumes (alone, from its own
config), refuses a used --out and bad files in one line; config overrides; the vector env speaks
gymnasium's VectorEnv API."""
import csv
import math
import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import torch
import yaml
from cage_sim.vec_env import CageNavVecEnv
from safetensors.torch import load_file

from cage_reactive_ddpg import config as config_mod
from cage_reactive_ddpg.study1d import evaluate_1d
from cage_reactive_ddpg.train import Trainer, main


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


def test_env_workers_fill_the_same_buffer_and_learn_beside_the_envs(tmp_path, tiny_overrides):
    """Two env worker processes (the envs and the expert's labels there): while the actions are the
    prefill's random ones, the buffer (labels included) and the episodes are bit-identical to one
    process when the sonar draws no noise; with updates, they run while the workers fly a step (the
    same number, less one step's: each step learns from the buffer before its own transitions), and
    the checkpoint holds every env's generator."""
    over = {**tiny_overrides, "scenario": "cage", "total_steps": 480, "n_envs": 4, "prefill_steps": 480,
            "eval_episodes": 0, "expert": "baseline", "expert_fraction": 0.5, "bc_weight": 1.0}
    a, _ = _train(tmp_path, "one", over)
    b, _ = _train(tmp_path, "two", {**over, "env_workers": 2})
    sa, sb = a.buffer.state(), b.buffer.state()
    assert a.buffer.size == b.buffer.size == 480 and all(np.array_equal(sa[k], sb[k], equal_nan=True) for k in sa)
    assert [{**r, "seconds": 0} for r in a.rows] == [{**r, "seconds": 0} for r in b.rows] and a.episodes > 5
    assert len(torch.load(b.out / "checkpoint.pt", weights_only=True)["env_rngs"]) == 4
    assert not any(p.is_alive() for p in b.envs._procs)            # run() ended its workers
    c, _ = _train(tmp_path, "learn", {**over, "env_workers": 2, "total_steps": 800, "prefill_steps": 200})
    d, _ = _train(tmp_path, "learn1", {**over, "total_steps": 800, "prefill_steps": 200})
    assert 0 <= d.updates - c.updates <= 4 and c.updates > 500   # the first step's updates wait for a batch
    assert all(torch.isfinite(v).all() for v in load_file(str(c.out / "policy.safetensors")).values())
    with pytest.raises(ValueError, match="env_workers: must be between 1 and n_envs"):
        config_mod.build("study", overrides={**over, "env_workers": 5})


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
    # YAML 1.1 reads 5e-4 (no dot) as a string, on the command line and in a file alike
    f.write_text("lr_critic: 8e-4\n")
    cfg = config_mod.build(file=f, overrides=["lr_actor=5e-4"])
    assert (cfg.lr_actor, cfg.lr_critic) == (5e-4, 8e-4)
    with pytest.raises(ValueError, match="tau: expected float, got 'fast'"):
        config_mod.build(overrides=["tau=fast"])


def _write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def test_extends_reads_the_parent_first_and_merges_reward(tmp_path):
    """A variant names only what it changes: the parent's keys, then its own; reward term by term;
    the path is relative to the variant's file; the preset comes from the chain."""
    _write(tmp_path / "base.yaml", "preset: study_low_lr\nbatch_size: 96\ngamma: 0.95\n"
                                   "reward:\n  goal: 5\n  progress_weight: 0.5\n")
    child = _write(tmp_path / "variants" / "child.yaml",
                   "extends: ../base.yaml\nbatch_size: 128\nreward:\n  goal: 7\n")
    cfg = config_mod.build(file=child)
    assert (cfg.batch_size, cfg.gamma, cfg.lr_critic) == (128, 0.95, 1e-4)     # own, parent's, preset's
    assert cfg.reward == {"goal": 7.0, "progress_weight": 0.5}
    grandchild = _write(tmp_path / "g.yaml", "extends: variants/child.yaml\npreset: study\ngamma: 0.9\n")
    cfg = config_mod.build(file=grandchild, overrides=["batch_size=64"])
    assert (cfg.batch_size, cfg.gamma, cfg.lr_critic) == (64, 0.9, 1e-3)      # --set, own, own preset
    assert "extends" not in config_mod.read_file(grandchild) and "extends" not in cfg.to_dict()


@pytest.mark.parametrize("files,expect", [
    ({"a.yaml": "extends: b.yaml\n", "b.yaml": "extends: a.yaml\n"}, r"extends itself \(a.yaml -> b.yaml -> a.yaml\)"),
    ({"a.yaml": "extends: a.yaml\n"}, "extends itself"),
    ({"a.yaml": "extends: nowhere.yaml\n"}, r"a.yaml: extends nowhere.yaml: no such file"),
    ({"a.yaml": "extends: [b.yaml]\n"}, "extends: expected a file name"),
    ({"a.yaml": "extends: b.yaml\n", "b.yaml": "gamm: 0.9\n"}, "gamm: unknown config key"),
])
def test_a_bad_extends_chain_is_an_error_naming_the_file(tmp_path, files, expect):
    for name, text in files.items():
        _write(tmp_path / name, text)
    with pytest.raises(ValueError, match=expect):
        config_mod.build(file=tmp_path / "a.yaml")


def test_print_config_expands_extends_and_writes_nothing(tmp_path, monkeypatch, capsys):
    """``train --print-config`` shows the config a run would record; read back, it builds the same."""
    monkeypatch.chdir(tmp_path)
    path = CONFIG_DIR / "sea_residual_replay_fls.yaml"
    assert main(["--config", str(path), "--set", "seed=7", "--print-config"]) == 0
    printed = yaml.safe_load(capsys.readouterr().out)
    assert "extends" not in printed and printed["sensor"] == "fls" and printed["seed"] == 7
    assert printed["replay_fraction"] == 0.25 and printed["expert"] == "flown"       # the parent's recipe
    back = _write(tmp_path / "printed.yaml", yaml.safe_dump(printed))
    assert config_mod.build(file=back) == config_mod.build(file=path, overrides=["seed=7"])
    assert not any(tmp_path.glob("runs*"))


def test_a_run_from_a_variant_records_the_expanded_config(tmp_path, tiny_overrides):
    """policy.json and config.yaml hold every key, so a run is rebuilt without its config files."""
    from cage_reactive_ddpg.policy import load_policy
    _write(tmp_path / "cfg" / "base.yaml", "preset: study\nscenario: study2d\nn_envs: 2\n"
                                          "prefill_steps: 100\neval_episodes: 2\nreward:\n  goal: 3\n")
    child = _write(tmp_path / "cfg" / "child.yaml", "extends: base.yaml\nbatch_size: 48\n")
    out = tmp_path / "run"
    tiny = {k: v for k, v in tiny_overrides.items() if k not in ("batch_size", "eval_episodes")}
    assert main(["--config", str(child), "--steps", "200", "--out", str(out), "--quiet",
                 *[x for k, v in tiny.items() for x in ("--set", f"{k}={v}")]]) == 0
    recorded = load_policy(out / "policy.safetensors").metadata["config"]
    assert "extends" not in recorded and recorded["scenario"] == "study2d" and recorded["batch_size"] == 48
    assert recorded["reward"] == {"goal": 3.0} and recorded == yaml.safe_load((out / "config.yaml").read_text())
    assert config_mod.from_dict(recorded) == config_mod.build(file=child, overrides=tiny | {"total_steps": 200})


CONFIG_DIR = Path(config_mod.__file__).parents[1] / "config"
TRAINING_CONFIGS = sorted(p.stem for p in CONFIG_DIR.glob("*.yaml")
                          if not p.stem.startswith("sweep"))     # sweep*.yaml are search spaces (test_sweep)


def test_the_shipped_configs_are_found():
    assert {"sea_residual_replay", "sea_residual_replay_fls", "sea_guided_fls", "shipped"} <= set(TRAINING_CONFIGS)


VARIANT_CONFIGS = [n for n in TRAINING_CONFIGS if "extends" in yaml.safe_load((CONFIG_DIR / f"{n}.yaml").read_text())]


def test_the_profile_variants_extend_their_recipe():
    assert {"sea_residual_replay_fls", "sea_residual_replay_mb360", "sea_residual_replay_scanning",
            "sea_guided_fls"} <= set(VARIANT_CONFIGS)


@pytest.mark.parametrize("name", VARIANT_CONFIGS)
def test_a_variant_config_repeats_no_key_of_its_parent(name):
    """A file that extends another states only what differs (so a change to the recipe reaches
    every variant), and it differs in something."""
    path = CONFIG_DIR / f"{name}.yaml"
    own = yaml.safe_load(path.read_text())
    parent_path = path.parent / own.pop("extends")
    parent = config_mod.read_file(parent_path)
    repeated = sorted(k for k, v in own.items() if k != "reward" and parent.get(k) == v)
    repeated += sorted(f"reward.{k}" for k, v in (own.get("reward") or {}).items()
                       if (parent.get("reward") or {}).get(k) == v)
    assert not repeated, f"{name}.yaml repeats its parent's {repeated}"
    assert config_mod.build(file=path) != config_mod.build(file=parent_path)


@pytest.mark.parametrize("name", TRAINING_CONFIGS)
def test_every_shipped_training_config_builds_and_builds_its_env(name):
    path = CONFIG_DIR / f"{name}.yaml"
    cfg = config_mod.build(file=path)
    env = cfg.env_config()
    assert cfg.total_steps > 0 or cfg.episodes > 0
    if "sensor:" in path.read_text():
        assert env.sonar.profile == cfg.sensor


def test_memory_only_options_reach_the_policy_file_and_the_evaluator(tmp_path, tiny_overrides):
    """memory_horizon and scan_in_obs (the scanning policy's observation: the motion-compensated
    memory without the raw sweep) are in the trained file, and ``env_config_for`` rebuilds the same
    layout from it: the evaluator and policy_node observe as the trainer did."""
    from cage_reactive_ddpg.policy import env_config_for, load_policy
    over = {**tiny_overrides, "scenario": "cage", "sensor": "scanning", "observation": "v2", "velocity": True,
            "memory_bins": 36, "memory_horizon": 6.0, "scan_in_obs": False, "n_envs": 2, "prefill_steps": 100,
            "eval_episodes": 2, "sensor_settings": "{beam_width_deg: 3.0, sweep_time: 2.0}"}
    out = tmp_path / "run"
    assert main(["--steps", "200", "--out", str(out), "--quiet", *[x for k, v in over.items()
                                                                     for x in ("--set", f"{k}={v}")]]) == 0
    pol = load_policy(out / "policy.safetensors", profile="scanning")
    layout = env_config_for(pol.metadata).layout
    assert (layout.scan, layout.memory_bins, layout.memory_horizon) == (False, 36, 6.0)
    assert layout == pol.layout and layout.size == 36 + 2 + 2
    # the sonar's own settings too (sensor_settings), which the layout does not show
    sonar = env_config_for(pol.metadata).sonar
    assert pol.metadata["sonar"]["beam_width_deg"] == pytest.approx(3.0)
    assert (math.degrees(sonar.beam_width), sonar.sweep_time) == (pytest.approx(3.0), 2.0)


@pytest.mark.parametrize("settings, expect", [
    ({"beam_width_deg": 45.0}, "sensor / sensor_settings: sonar.beam_width: must be in"),
    ({"beam_wdth_deg": 2.0}, "sonar.beam_wdth_deg: unknown setting"),
    ({"noise_std": "lots"}, "sonar.noise_std: expected a number"),
    ("2 deg", "sensor_settings: expected dict"),
])
def test_bad_sensor_settings_are_refused_naming_the_setting(settings, expect):
    with pytest.raises(ValueError, match=re.escape(expect)):
        config_mod.build(overrides={"sensor": "multibeam360", "sensor_settings": settings})


@pytest.mark.parametrize("settings, expect", [
    ({"expert": "flown", "expert_remembered": "some"}, "expert_remembered: must be one of all, out_of_view, cleared"),
    ({"expert": "baseline", "expert_remembered": "cleared"}, "expert_remembered: cleared needs expert: flown"),
])
def test_a_bad_expert_memory_is_refused_naming_the_field(settings, expect):
    with pytest.raises(ValueError, match=re.escape(expect)):
        config_mod.build(overrides=settings)


def _cli_tiny(tiny):
    """--set flags of a tiny study2d run."""
    over = {**tiny, "scenario": "study2d", "n_envs": 4, "prefill_steps": 200, "eval_episodes": 5,
            "checkpoint_every": 300, "tensorboard": True}
    return [x for k, v in over.items() for x in ("--set", f"{k}={v}")]


def _episodes(path):
    with path.open() as f:
        return [int(r["episode"]) for r in csv.DictReader(f)]


def test_resume_alone_restores_config_and_whole_curve(tmp_path, tiny_overrides, capsys):
    out = tmp_path / "run"
    assert main(["--preset", "study", "--steps", "600", "--out", str(out), "--quiet", *_cli_tiny(tiny_overrides)]) == 0
    first = _episodes(out / "episodes.csv")
    # a fresh run into the used folder is refused in one line, exit 2; the run is untouched
    assert main(["--preset", "study", "--steps", "600", "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("train: ") and "not empty" in err and "--resume" in err and "\n" not in err
    assert _episodes(out / "episodes.csv") == first
    # --resume DIR alone (plus a larger budget): the checkpoint's own 32-32 nets, not the 400-300 defaults
    assert main(["--resume", str(out), "--steps", "1000", "--quiet"]) == 0
    state = torch.load(out / "checkpoint.pt", weights_only=True)
    assert state["config"]["critic_hidden"] == [32, 32] and state["progress"]["step"] == 1000
    eps = _episodes(out / "episodes.csv")
    assert eps == list(range(1, len(eps) + 1)) and len(eps) > len(first)   # whole run, no gap, no repeat
    assert len(state["evals"]) == 2                                           # both runs' evaluations
    # --force starts over
    assert main(["--preset", "study", "--steps", "300", "--out", str(out), "--quiet", "--force",
                 *_cli_tiny(tiny_overrides)]) == 0
    assert torch.load(out / "checkpoint.pt", weights_only=True)["progress"]["step"] == 300


def test_tensorboard_x_axis_is_env_steps(tmp_path, tiny_overrides, monkeypatch):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    from cage_reactive_ddpg import train
    monkeypatch.setattr(train, "LOG_EVERY", 400)
    out = tmp_path / "tb"
    assert main(["--preset", "study", "--steps", "600", "--out", str(out), "--quiet", *_cli_tiny(tiny_overrides)]) == 0
    acc = EventAccumulator(str(out / "tb"))
    acc.Reload()
    tags = set(acc.Tags()["scalars"])
    assert {"episode/reward", "episode/length", "episode/success", "time/fps", "train/noise_std",
            "eval/goal", "hparam/goal"} <= tags
    steps = [e.step for e in acc.Scalars("episode/reward")]
    assert steps == sorted(steps) and 100 < steps[-1] <= 600   # env steps, not episode numbers
    assert [e.step for e in acc.Scalars("time/fps")] == [400]


@pytest.mark.parametrize("content,expect", [
    (b"not a checkpoint", "not a trainer checkpoint"),
    (None, "no such checkpoint"),
])
def test_bad_checkpoint_is_one_line(tmp_path, capsys, content, expect):
    ck = tmp_path / "checkpoint.pt"
    if content is not None:
        ck.write_bytes(content)
    assert main(["--resume", str(ck), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("train: ") and expect in err and "Traceback" not in err


def test_bad_config_and_mismatched_checkpoint_are_one_line(tmp_path, tiny_overrides, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("batch_size: [1,\n")
    assert main(["--config", str(bad), "--out", str(tmp_path / "x")]) == 2
    assert "not valid YAML" in capsys.readouterr().err
    out = tmp_path / "run"
    assert main(["--preset", "study", "--steps", "300", "--out", str(out), "--quiet", *_cli_tiny(tiny_overrides)]) == 0
    capsys.readouterr()
    assert main(["--resume", str(out), "--set", "critic_hidden=[64, 64]", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "does not fit this trainer and config" in err


def test_vec_env_is_a_gymnasium_vector_env():
    from gymnasium.wrappers.vector import ClipAction, NormalizeObservation, RecordEpisodeStatistics
    venv = CageNavVecEnv(3, "study2d", seed=1)
    assert isinstance(venv, gym.vector.VectorEnv)
    assert venv.metadata["autoreset_mode"] == gym.vector.AutoresetMode.SAME_STEP
    assert venv.observation_space.shape == (3, *venv.single_observation_space.shape)
    env = RecordEpisodeStatistics(ClipAction(venv))
    obs, info = env.reset(seed=5)
    assert obs.shape == venv.observation_space.shape and info["outcome"].tolist() == [None] * 3
    ended = 0
    for _ in range(150):
        obs, rew, term, trunc, info = env.step(env.action_space.sample() * 0 + 2.0)   # clipped to 1
        assert obs.shape == (3, venv.single_observation_space.shape[0]) and rew.shape == (3,)
        done = term | trunc
        if done.any():
            assert (info["_final_obs"] == done).all() and (info["_episode"] == done).all()
            for i in np.flatnonzero(done):
                ended += 1
                assert info["final_info"]["outcome"][i] in ("goal", "collision", "wander", "timeout")
                assert info["final_info"]["is_success"][i] == (info["final_info"]["outcome"][i] == "goal")
                assert info["episode"]["l"][i] == info["final_info"]["steps"][i]
    assert ended >= 3
    # reset(seed=...) fixes every env's episodes
    a, _ = venv.reset(seed=11)
    b, _ = venv.reset(seed=11)
    assert np.array_equal(a, b)
    # next_step mode: gymnasium's observation wrappers accept it; a done env restarts a step later
    nxt = NormalizeObservation(CageNavVecEnv(2, "study2d", seed=1, autoreset_mode="next_step"))
    nxt.reset(seed=2)
    was_done = np.zeros(2, bool)
    for _ in range(120):
        obs, rew, term, trunc, info = nxt.step(np.full((2, 1), 1.0))
        assert not (term | trunc)[was_done].any() and (rew[was_done] == 0).all()
        was_done = term | trunc
    assert np.isfinite(obs).all()
