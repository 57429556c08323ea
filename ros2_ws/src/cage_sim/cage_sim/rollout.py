"""Run one episode of a policy in an env and keep what the evaluator and the plots need."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from .controller import Policy
from .driver import Driver, decide_batch, mission_moment
from .env import CageNavEnv
from .scenarios import Scenario


@dataclass
class Episode:
    scenario: Scenario
    outcome: str
    steps: int
    reward: float
    travelled: float
    route_length: float
    track: list = field(default_factory=list)
    min_clearance: float = float("inf")


def run_episode(env: CageNavEnv, policy: Policy, seed: int | None = None,
                scenario: Scenario | None = None) -> Episode:
    """One seeded episode; the same seed gives the same scenario and the same outcome."""
    return _fly(env, lambda obs: policy.act(obs), seed, scenario)


def drive_episode(env: CageNavEnv, driver: Driver, seed: int | None = None,
                  scenario: Scenario | None = None, known_map: bool = True) -> Episode:
    """One seeded episode decided by ``driver`` exactly as policy_node decides (``cage_sim.driver``:
    perception with the DVL's drift and the returns' motion; a shield with the mission's known map,
    as policy_node gets it on ``map``, unless ``known_map`` is off): the graph's offline reference."""
    def act(obs):
        return decide_batch([driver], np.asarray(obs)[None], [mission_moment(env.mission)])[0]

    def before():
        driver.reset()
        driver.use_builder(env.mission.builder)     # the memory the observations are built with
        driver.known = env.mission.map_points if known_map else None
    return _fly(env, act, seed, scenario, before=before)


def _fly(env: CageNavEnv, act: Callable[[np.ndarray], np.ndarray], seed: int | None,
         scenario: Scenario | None, before: Callable[[], None] | None = None) -> Episode:
    """The episode loop both share: reset, act on each observation until the mission ends, and keep
    the reward, track and the closest approach (fish where they are at each step)."""
    obs, info = env.reset(seed=seed, options={"scenario": scenario} if scenario else None)
    m = env.mission
    if before is not None:
        before()
    total, min_clear = 0.0, m.scene.clearance(m.x, m.y)
    while True:
        obs, r, term, trunc, info = env.step(act(obs))
        total += r
        min_clear = min(min_clear, m.scene.clearance(m.x, m.y, m.t))   # fish where they are now
        if term or trunc:
            break
    return Episode(m.scenario, info["outcome"], info["steps"], total, info["travelled"],
                   info["route_length"], list(m.track), min_clear)
