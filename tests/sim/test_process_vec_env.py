"""ProcessVecEnv: the envs in worker processes answer as one CageNavVecEnv does (observations,
rewards, outcomes, final observations and infos, in env order), the expert's labels come back with
each observation, generator states round-trip, and a dead worker is one clear error."""
import os
import signal

import numpy as np
import pytest

from cage_sim.controller import ArcController
from cage_sim.driver import FlownLabeller, ObservationLabeller
from cage_sim.mission import EnvConfig
from cage_sim.process_vec_env import ProcessVecEnv
from cage_sim.vec_env import CageNavVecEnv, finished


@pytest.fixture
def pair():
    cfg = EnvConfig()                       # study sonar: no noise, so every draw is the scenario generators'
    one = CageNavVecEnv(5, "cage", cfg, seed=5)
    two = ProcessVecEnv(5, 2, "cage", cfg, seed=5, labeller=ObservationLabeller(ArcController(cfg.layout, cfg.vehicle)))
    yield one, two, ArcController(cfg.layout, cfg.vehicle)
    two.close()


def test_workers_answer_as_one_vector_env(pair):
    one, two, expert = pair
    assert two.observation_space == one.observation_space and two.slices[0].tolist() == [0, 1, 2]
    o1, i1 = one.reset()
    o2, i2 = two.reset()
    assert np.array_equal(o1, o2) and np.array_equal(i2["labels"], expert.act(o2))
    rng, ended = np.random.default_rng(0), 0
    for _ in range(60):
        a = rng.uniform(-1, 1, (5, 1))
        r1, r2 = one.step(a), two.step(a)
        for x, y in zip(r1[:4], r2[:4]):
            assert np.array_equal(x, y)
        inf1, inf2 = r1[4], r2[4]
        assert set(inf2) - set(inf1) == {"labels", "final_labels"}
        assert np.array_equal(inf2["labels"], expert.act(r2[0]))
        ends = dict(finished(inf1))
        for i in range(5):    # the expert's action on an ended episode's last observation, NaN elsewhere
            assert np.array_equal(inf2["final_labels"][i], expert.act(ends[i]) if i in ends else [np.nan],
                                  equal_nan=True)
        for k in ("outcome", "is_success", "steps"):
            assert inf1[k].dtype == inf2[k].dtype and inf1[k].tolist() == inf2[k].tolist()
        if "final_obs" in inf1:
            ended += int(inf1["_final_obs"].sum())
            assert np.array_equal(inf1["_final_obs"], inf2["_final_obs"])
            for i in np.flatnonzero(inf1["_final_obs"]):
                assert np.array_equal(inf1["final_obs"][i], inf2["final_obs"][i])
                assert inf1["final_info"]["outcome"][i] == inf2["final_info"]["outcome"][i]
                assert inf1["final_info"]["steps"][i] == inf2["final_info"]["steps"][i]
    assert ended >= 5                          # random actions end missions: the autoreset path ran


def test_step_async_then_wait_is_a_step(pair):
    one, two, _ = pair
    one.reset()
    two.reset()
    a = np.full((5, 1), 0.4)
    two.step_async(a)
    with pytest.raises(RuntimeError, match="in flight"):
        two.rng_states()
    r2 = two.step_wait()
    assert all(np.array_equal(x, y) for x, y in zip(one.step(a)[:4], r2[:4]))
    with pytest.raises(RuntimeError, match="without step_async"):
        two.step_wait()


def test_generator_states_round_trip_and_reseeding(pair):
    one, two, _ = pair
    states = two.rng_states()
    assert len(states) == 5 and states == one.rng_states()   # env i: the i-th child of SeedSequence(5)
    a, _ = two.reset()
    two.set_rng_states(states)
    b, _ = two.reset()
    assert np.array_equal(a, b)
    c, _ = two.reset(seed=11)
    d, _ = one.reset(seed=11)
    assert np.array_equal(c, d)
    with pytest.raises(ValueError, match="expected 5"):
        two.set_rng_states(states[:2])


def test_bad_worker_counts_and_a_dead_worker_are_clear():
    with pytest.raises(ValueError, match="env_workers"):
        ProcessVecEnv(2, 3, "cage")
    env = ProcessVecEnv(2, 2, "cage", seed=1)
    env.reset()
    os.kill(env._procs[1].pid, signal.SIGKILL)
    env._procs[1].join()
    with pytest.raises(RuntimeError, match="worker process ended"):
        env.step(np.zeros((2, 1)))
    env.close()
    assert not any(p.is_alive() for p in env._procs)


def test_flown_labels_from_workers_are_the_flown_baseline_in_one_process():
    """``FlownLabeller`` keeps one driver per env across steps (returns' motion, new missions reset
    it); in the workers it labels exactly as in one process beside a ``CageNavVecEnv``, where the
    schools move and the current drifts the vehicle."""
    cfg = EnvConfig()
    scenario = "cage?current=0.4&schools=3"
    ctrl = ArcController(cfg.layout, cfg.vehicle)
    one, here = CageNavVecEnv(4, scenario, cfg, seed=3), FlownLabeller(ctrl)
    two = ProcessVecEnv(4, 2, scenario, cfg, seed=3, labeller=FlownLabeller(ArcController(cfg.layout, cfg.vehicle)))
    try:
        o1, _ = one.reset()
        _, i2 = two.reset()
        assert np.array_equal(here(o1, one.missions)[0], i2["labels"])
        rng, ended, differs = np.random.default_rng(1), 0, 0
        for _ in range(80):
            a = rng.uniform(-1, 1, (4, 1))
            o1, *_, inf1 = one.step(a)
            *_, inf2 = two.step(a)
            lab, fin = here(o1, one.missions, finished(inf1))
            assert np.array_equal(lab, inf2["labels"]) and np.array_equal(fin, inf2["final_labels"], equal_nan=True)
            ended += int(np.isfinite(fin).sum())
            differs += int((lab != ObservationLabeller(ctrl)(o1, one.missions)[0]).sum())
        assert ended >= 2 and differs > 0     # episodes ended; perception changed some actions
    finally:
        two.close()
