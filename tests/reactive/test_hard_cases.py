"""Hard-case replay: failed missions are flown again (the same mission), a bounded number of times,
and only when asked for; with replay off the training streams are those of before."""
import json

import numpy as np
import pytest
from cage_sim.mission import EnvConfig
from cage_sim.process_vec_env import ProcessVecEnv
from cage_sim.vec_env import CageNavVecEnv

from cage_reactive_ddpg import config as config_mod
from cage_reactive_ddpg.hard_cases import HardCaseReplay
from cage_reactive_ddpg.train import Trainer


def test_keeps_failures_only_and_hands_them_back_oldest_first_within_max_tries():
    r = HardCaseReplay(1.0, max_tries=2)
    r.offer("a", "goal", 1)
    r.offer("b", "collision", 1)
    r.offer("c", "timeout", 1)
    r.offer("d", "collision", 3)                 # flown too often already
    assert r.draw() == ("b", 2) and r.draw() == ("c", 2) and r.draw() is None
    assert r.stats() == {"offered": 4, "kept": 2, "replayed": 2, "waiting": 0}
    never = HardCaseReplay(0.0)
    never.offer("b", "collision", 1)
    assert all(never.draw() is None for _ in range(50))
    half = HardCaseReplay(0.5, seed=3)
    for k in range(400):
        half.offer(k, "wander", 1)
    assert 150 < sum(half.draw() is not None for _ in range(400)) < 250


@pytest.mark.parametrize("kw, message", [({"fraction": 1.5}, "replay_fraction"), ({"fraction": 0.5, "max_tries": 0}, "max_tries"),
                                         ({"fraction": 0.5, "outcomes": ("goal",)}, "not failures")])
def test_bad_settings_are_refused(kw, message):
    with pytest.raises(ValueError, match=message):
        HardCaseReplay(**kw)


def test_a_failed_mission_is_flown_again_by_the_vector_env():
    replay = HardCaseReplay(1.0, max_tries=2)
    env = CageNavVecEnv(1, "cage", EnvConfig(), seed=4, replay=replay)
    env.reset()
    first = env.missions[0].scenario
    seen = []
    for _ in range(400):                          # a hard left turn for ever: it fails, then fails again
        _, _, term, trunc, infos = env.step(np.array([[1.0]]))
        if term[0] or trunc[0]:
            assert infos["outcome"][0] != "goal"
            seen.append(env.missions[0].scenario)
        if len(seen) == 2:
            break
    assert seen[0].to_dict() == first.to_dict()              # the failed mission again
    assert seen[1].to_dict() != first.to_dict()              # flown twice: a fresh one now
    assert replay.stats()["replayed"] == 1


def test_a_replay_that_never_fires_leaves_the_missions_as_they_were():
    """The replay draws its own random numbers: off, or at fraction 0, the envs meet the very
    missions they met before it existed."""
    envs = [CageNavVecEnv(3, "cage", EnvConfig(), seed=9, replay=r) for r in (None, HardCaseReplay(0.0))]
    seen = [[], []]
    for e in envs:
        e.reset()
    for _ in range(150):
        for k, e in enumerate(envs):
            _, _, term, trunc, _ = e.step(np.full((3, 1), 0.7))
            seen[k] += [e.missions[i].scenario.to_dict() for i in np.flatnonzero(term | trunc)]
    assert len(seen[0]) > 5 and seen[0] == seen[1]


def test_failed_missions_are_flown_again_in_the_worker_they_failed_in():
    """The replay pool lives in the parent: a worker's failed mission comes back to that worker and
    starts at its next mission end (one end later than in one process), at most max_tries times."""
    replay = HardCaseReplay(1.0, max_tries=2)
    env = ProcessVecEnv(2, 2, "cage", EnvConfig(), seed=4, replay=replay)   # study sonar: no noise
    try:
        obs, _ = env.reset()
        starts = [[obs[0]], [obs[1]]]          # each mission's first observation, env by env
        for _ in range(1500):                  # a hard left turn for ever: every mission fails
            obs, _, term, trunc, infos = env.step(np.ones((2, 1)))
            assert not any(o == "goal" for o in infos["outcome"])
            for i in np.flatnonzero(term | trunc):
                starts[i].append(obs[i])
            if min(len(s) for s in starts) >= 5:
                break
        for s in starts:                       # A, B, then A and B again (try 2), then a fresh C
            assert np.array_equal(s[2], s[0]) and np.array_equal(s[3], s[1])
            assert not any(np.array_equal(s[4], t) for t in s[:4])
        assert not np.array_equal(starts[0][0], starts[1][0])
        stats = replay.stats()
        assert stats["replayed"] >= 4 and stats["offered"] >= 8 and stats["kept"] >= 4
    finally:
        env.close()


def test_a_replay_that_never_fires_leaves_the_workers_missions_as_they_were():
    envs = [ProcessVecEnv(3, 2, "cage", EnvConfig(), seed=9, replay=r) for r in (None, HardCaseReplay(0.0))]
    try:
        for e in envs:
            e.reset()
        for _ in range(150):
            a = np.full((3, 1), 0.7)
            r0, r1 = envs[0].step(a), envs[1].step(a)
            assert all(np.array_equal(x, y) for x, y in zip(r0[:4], r1[:4]))
        assert envs[1].replay.stats()["offered"] > 3
    finally:
        for e in envs:
            e.close()


@pytest.mark.parametrize("workers", [1, 2])
def test_trainer_records_the_replay(tmp_path, tiny_overrides, workers):
    over = {**tiny_overrides, "scenario": "cage", "total_steps": 600, "prefill_steps": 300, "n_envs": 4,
            "eval_episodes": 0, "replay_fraction": 0.5, "env_workers": workers}
    tr = Trainer(config_mod.build("fast", overrides=over), tmp_path, progress=False)
    tr.run()
    stats = json.loads((tmp_path / "policy.json").read_text())["training"]["hard_case_replay"]
    assert stats["offered"] == tr.episodes and stats["kept"] > 0 and stats["replayed"] > 0
