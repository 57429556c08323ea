"""The shield in the training loop (``shield_in_loop``): the env flies what the evaluator's shield lets
through, the same in env worker processes as in one, and the trainer charges every override."""
import numpy as np
import pytest
from cage_sim.controller import ArcController
from cage_sim.driver import ShieldFilter
from cage_sim.mission import EnvConfig
from cage_sim.process_vec_env import ProcessVecEnv
from cage_sim.vec_env import CageNavVecEnv

from cage_reactive_ddpg import config as config_mod
from cage_reactive_ddpg.train import Trainer

# The study sonar draws no noise, so two envs of one seed meet the same missions and scans.
ENV = EnvConfig(observation="v2", velocity=True, memory_bins=72)
SCENARIO = "cage?current=0.4&obstacles=small&schools=2"


def _shield() -> ShieldFilter:
    return ShieldFilter(ArcController(ENV.layout, ENV.vehicle))


def _fly(env, proposals) -> tuple[list, np.ndarray, np.ndarray]:
    """(outcomes of the missions that ended, rewards (steps, n), shielded flags (steps, n))."""
    env.reset()
    outcomes, rewards, flags = [], [], []
    for a in proposals:
        _, rew, _, _, infos = env.step(a)
        outcomes += [o for o in infos["outcome"] if o is not None]
        rewards.append(rew)
        flags.append(infos.get("shielded", np.zeros(len(rew), dtype=bool)))
    return outcomes, np.array(rewards), np.array(flags)


def test_a_hard_turn_proposed_at_every_step_is_flown_safely_behind_the_shield():
    """An actor that only ever proposes a hard left turn circles into the net and the obstacles on
    its own. Behind the filter the shield replaces the turn wherever it is unsafe, and in open
    water the controller flies at the waypoint, so missions end at the goal and far fewer collide."""
    turns = [np.ones((6, 1))] * 250
    bare, _, none = _fly(CageNavVecEnv(6, SCENARIO, ENV, seed=2), turns)
    shielded, _, flags = _fly(CageNavVecEnv(6, SCENARIO, ENV, seed=2, action_filter=_shield()), turns)
    assert not none.any()
    assert bare.count("goal") == 0 and bare.count("collision") >= 3
    assert shielded.count("goal") >= 3 and shielded.count("collision") < bare.count("collision")
    assert 0.05 < flags.mean() < 0.95          # replaced where unsafe or in open water, not everywhere


def test_workers_fly_behind_their_own_copy_of_the_shield_as_one_process_does():
    """Each worker's filter keeps its own drivers (returns' motion, manoeuvre in hand, stall watch):
    the flags and rewards come back exactly as from one process."""
    rng = np.random.default_rng(4)
    proposals = [rng.uniform(-1, 1, (4, 1)) for _ in range(120)]
    one = _fly(CageNavVecEnv(4, SCENARIO, ENV, seed=7, action_filter=_shield()), proposals)
    pool = ProcessVecEnv(4, 2, SCENARIO, ENV, seed=7, action_filter=_shield())
    try:
        two = _fly(pool, proposals)
    finally:
        pool.close()
    assert one[0] == two[0] and len(one[0]) >= 4
    assert np.array_equal(one[1], two[1]) and np.array_equal(one[2], two[2]) and one[2].any()


def _shielded_run(tmp_path, name, tiny_overrides, penalty):
    over = {**tiny_overrides, "scenario": SCENARIO, "motion": "continuous", "planner": "rrt",
            "total_steps": 600, "n_envs": 4, "prefill_steps": 600, "eval_episodes": 3, "velocity": True,
            "observation": "v2", "memory_bins": 72, "expert": "flown", "residual": True, "bc_weight": 1.0,
            "shield_in_loop": True, "shield_penalty": penalty}
    tr = Trainer(config_mod.build("fast", overrides=over), tmp_path / name, progress=False)
    tr.run()
    return tr


def test_training_behind_the_shield_charges_each_override(tmp_path, tiny_overrides):
    """With the prefill's random actions both runs fly the same missions the same way; the penalty
    takes exactly ``shield_penalty`` per replaced action off each episode's reward. Every decision
    went through the shield, with a residual actor's base as its fallback (as the evaluator does),
    and the evaluations fly behind it too."""
    free = _shielded_run(tmp_path, "free", tiny_overrides, 0.0)
    charged = _shielded_run(tmp_path, "charged", tiny_overrides, 2.0)
    assert free.shield.shield.decisions == charged.shield.shield.decisions == 600
    assert [r["shielded"] for r in free.rows] == [r["shielded"] for r in charged.rows]
    assert sum(r["shielded"] for r in free.rows) > 0 and len(free.rows) >= 4
    for a, b in zip(free.rows, charged.rows):
        assert b["reward"] == pytest.approx(a["reward"] - 2.0 * a["shielded"], abs=2e-3)
    assert free.shield.shield.fallback.tunables() == free.expert.tunables()
    assert "shielded" in (tmp_path / "free" / "episodes.csv").read_text().splitlines()[0]
    assert free.evals[-1]["driver"] == "shield" and free.evals[-1]["episodes"] == 3


@pytest.mark.parametrize("over, expect", [
    ({"shield_penalty": 0.5}, "shield_penalty: needs shield_in_loop"),
    ({"shield_in_loop": True, "shield_penalty": -1.0}, "shield_penalty: must be a finite number >= 0"),
    ({"shield_in_loop": True, "motion": "study"}, "shield_in_loop: needs motion: continuous"),
])
def test_bad_shield_in_loop_settings_are_refused(over, expect):
    with pytest.raises(ValueError, match=expect):
        config_mod.build("rrt", overrides=over)
