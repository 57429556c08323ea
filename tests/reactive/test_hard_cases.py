"""Hard-case replay: failed missions are flown again (the same mission), a bounded number of times,
and only when asked for; with replay off the training streams are those of before."""
import json

import numpy as np
import pytest
from cage_sim.mission import EnvConfig
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


def test_trainer_records_the_replay(tmp_path, tiny_overrides):
    over = {**tiny_overrides, "scenario": "cage", "total_steps": 600, "prefill_steps": 300, "n_envs": 4,
            "eval_episodes": 0, "replay_fraction": 0.5}
    tr = Trainer(config_mod.build("fast", overrides=over), tmp_path, progress=False)
    tr.run()
    stats = json.loads((tmp_path / "policy.json").read_text())["training"]["hard_case_replay"]
    assert stats["offered"] == tr.episodes and stats["kept"] > 0 and stats["replayed"] > 0
