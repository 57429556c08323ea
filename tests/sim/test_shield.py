"""The safety shield: leaves safe actions alone, overrides the ones no manoeuvre can recover from."""
import numpy as np

from cage_sim.controller import ArcController
from cage_sim.env import CageNavEnv
from cage_sim.rollout import run_episode
from cage_sim.scenarios import Scenario
from cage_sim.shield import SafetyShield
from cage_sim.world import Obstacle, World


class Constant:
    """A 'policy' that always gives the same action."""

    def __init__(self, a: float):
        self.a = a

    def act(self, obs):
        return np.full((1,) if np.ndim(obs) == 1 else (len(obs), 1), self.a, dtype=np.float32)


def wall_ahead() -> Scenario:
    # A row of squares across the straight route: flying straight on hits it.
    wall = tuple(Obstacle("square", 8.0, y, 2.0) for y in (-4.0, -2.0, 0.0, 2.0, 4.0))
    return Scenario("wall", World(30.0, (), wall), (0.0, 0.0, 0.0), (20.0, 8.0))


def test_open_water_is_left_alone():
    sc = Scenario("open", World(30.0), (0.0, 0.0, 0.0), (15.0, 0.0))
    shield = SafetyShield(Constant(0.0))
    ep = run_episode(CageNavEnv(sc), shield, seed=0)
    assert ep.outcome == "goal" and shield.interventions == 0 and shield.decisions == ep.steps


def test_a_policy_flying_into_a_wall_is_stopped_and_the_override_is_minimal():
    raw = run_episode(CageNavEnv(wall_ahead()), Constant(0.0), seed=0)
    assert raw.outcome == "collision"
    shield = SafetyShield(Constant(0.0))
    ep = run_episode(CageNavEnv(wall_ahead()), shield, seed=0)
    assert ep.outcome != "collision" and ep.min_clearance >= 0.5
    assert 0 < shield.interventions < shield.decisions     # it let the policy fly where that was safe


def test_safe_check_against_returns_directly():
    shield = SafetyShield(Constant(0.0))
    wall = np.array([(4.0, y) for y in np.linspace(-1, 1, 9)])    # a wall 4 m ahead, 2 m wide
    ok = shield.safe(np.array([-1.0, 0.0, 1.0]), wall)
    assert not ok[1]                      # straight on: no manoeuvre after it clears the wall by 1 m
    assert ok[0] and ok[2]                # a full turn (radius 2.9 m) now never comes within 1 m
    wide = np.array([(3.0, y) for y in np.linspace(-4, 4, 33)])   # 8 m wide, 3 m ahead: nothing helps
    assert not shield.safe(np.array([-1.0, 0.0, 1.0]), wide).any()
    assert shield.safe(np.array([0.0]), np.array([(30.0, 30.0)]))[0]


def test_batched_act_matches_single_and_is_deterministic():
    env = CageNavEnv("cage")
    obs, _ = env.reset(seed=3)
    batch = np.stack([obs, obs])
    a = SafetyShield(ArcController()).act(batch)
    b = SafetyShield(ArcController()).act(obs)
    assert a.shape == (2, 1) and b.shape == (1,) and a[0, 0] == a[1, 0] == b[0]
