"""Gymnasium environments over the cage simulation core.

Registered ids (importing this module registers them):
  CageNav-v0         full cage, random scenario per episode, known + unknown obstacles, route to follow
  CageNavMoving-v0   full cage with moving fish schools and a water current
  CageNavStudy2D-v0  the study's 2D case (one random obstacle)
  CageNavStudy1D-v0  the study's 1D sanity case
  CageNavSea-v0      exposed site: current 0-0.5 m/s (varying, net deformed), obstacles down to 0.15 m,
                     two fleeing schools; forward-looking sonar, memory (72 bins) and velocity over ground
                     (``SEA_FAMILY`` / ``SEA_CONFIG``)

Observation: ``EnvConfig.layout`` (see observation.py: v1, or v2 with the sensor profile, velocity over
ground and memory). Action: Box[-1, 1] scaled to +-20 deg. Step infos carry ``outcome`` and
``is_success`` (the goal was reached).
``CageNavVecEnv`` (vec_env.py, a gymnasium VectorEnv) steps many missions at once with one batched
sonar call, for fast training.
"""
from __future__ import annotations

from typing import Any, Callable, Sequence

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from .mission import EnvConfig, Mission
from .scenarios import Scenario, Sampler, scenario_sampler

WaypointFn = Callable[[Scenario], Sequence[Sequence[float]] | None]


def observation_space(config: EnvConfig) -> spaces.Box:
    lay = config.layout
    return spaces.Box(low=lay.low(), high=lay.high(), dtype=np.float32)


ACTION_SPACE = spaces.Box(low=-1.0, high=1.0, shape=(1,), dtype=np.float32)


def _prepare(sampler: Sampler, rng: np.random.Generator, waypoint_fn: WaypointFn | None) -> Scenario:
    sc = sampler(rng)
    if waypoint_fn is not None and not sc.waypoints:
        wps = waypoint_fn(sc)
        if wps is not None and len(wps):
            sc = sc.with_waypoints(wps)
    return sc


class CageNavEnv(gym.Env):
    """One AUV mission per episode: scenario drawn from ``scenario`` (name, YAML path, Scenario or
    sampler), route from the scenario, else from ``waypoint_fn`` (the global planner), else straight."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(self, scenario: Any = "cage", config: EnvConfig | None = None,
                 render_mode: str | None = None, waypoint_fn: WaypointFn | None = None):
        self.config = config or EnvConfig()
        self.sampler = scenario_sampler(scenario)
        self.waypoint_fn = waypoint_fn
        self.observation_space = observation_space(self.config)
        self.action_space = ACTION_SPACE
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']}")
        self.render_mode = render_mode
        self.mission: Mission | None = None

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        sc = (options or {}).get("scenario") or _prepare(self.sampler, self.np_random, self.waypoint_fn)
        # Fish schools move as in every other path (evaluate, the vector env, sim_node): Mission's own
        # seed, not a draw from this env's stream, so a seeded mission is the same mission everywhere.
        self.mission = Mission(sc, self.config)
        return self._obs(), self.mission.info()

    def step(self, action):
        if self.mission is None:
            raise RuntimeError("call reset() before step()")
        a = float(np.clip(np.asarray(action, dtype=np.float64).reshape(-1)[0], -1.0, 1.0))
        reward, outcome = self.mission.step(a)
        terminated = outcome in ("goal", "collision", "wander")
        truncated = outcome == "timeout"
        return self._obs(), float(reward), terminated, truncated, self.mission.info()

    def _obs(self) -> np.ndarray:
        return self.mission.observe(self.mission.sense(self.np_random))

    def render(self):
        if self.render_mode != "rgb_array" or self.mission is None:
            return None
        from .plotting import render_rgb
        return render_rgb(self.mission)


class Study1DEnv(gym.Env):
    """The study's 1D sanity case: start and goal uniform in [0, 10]; action in [-1, 1] is a step of
    up to 10 m. Reward per step 1 - |d|/d_max, +5 when within 0.5 m: reaching the goal in one step
    earns the study's best reward of 6. At most 10 steps. d_max (the start's distance) is floored at
    1 m: a start 1 cm from the goal would otherwise make an ordinary miss cost -1000 per step, and one
    such episode in the buffer is enough to wreck the critic (seen: 0 % goal on two of four seeds)."""

    metadata = {"render_modes": []}
    observation_space = spaces.Box(low=-1.0, high=1.0, shape=(1,), dtype=np.float32)
    action_space = ACTION_SPACE

    def __init__(self, render_mode: str | None = None, max_steps: int = 10):
        self.render_mode, self.max_steps = render_mode, max_steps
        self.pos = self.goal = self.d_max = 0.0
        self.steps = 0

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self.pos, self.goal = (float(v) for v in self.np_random.uniform(0.0, 10.0, 2))
        self.d_max, self.steps = max(abs(self.goal - self.pos), 1.0), 0
        return self._obs(), {"outcome": None, "steps": 0}

    def _obs(self) -> np.ndarray:
        return np.array([(self.goal - self.pos) / 10.0], dtype=np.float32)

    def step(self, action):
        self.pos += 10.0 * float(np.clip(np.asarray(action).reshape(-1)[0], -1.0, 1.0))
        self.steps += 1
        d = abs(self.goal - self.pos)
        reward = 1.0 - d / self.d_max
        outcome = None
        if d < 0.5:
            reward, outcome = reward + 5.0, "goal"
        elif self.steps >= self.max_steps:
            outcome = "timeout"
        return self._obs(), float(reward), outcome == "goal", outcome == "timeout", \
            {"outcome": outcome, "steps": self.steps}


def __getattr__(name: str):
    """``from cage_sim.env import CageNavVecEnv`` keeps working: it lives in vec_env.py (imported
    lazily, since vec_env builds on this module's spaces)."""
    if name == "CageNavVecEnv":
        from .vec_env import CageNavVecEnv
        return CageNavVecEnv
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


SEA_FAMILY = "cage?current=0-0.5&obstacles=mixed&schools=2"
SEA_CONFIG = EnvConfig(sonar="fls", velocity=True, memory_bins=72)


def _register() -> None:
    specs = {
        "CageNav-v0": {"scenario": "cage"},
        "CageNavMoving-v0": {"scenario": "cage_moving"},
        "CageNavStudy2D-v0": {"scenario": "study2d"},
        "CageNavSea-v0": {"scenario": SEA_FAMILY, "config": SEA_CONFIG},
    }
    for env_id, kwargs in specs.items():
        if env_id not in gym.registry:
            gym.register(env_id, entry_point="cage_sim.env:CageNavEnv", kwargs=kwargs)
    if "CageNavStudy1D-v0" not in gym.registry:
        gym.register("CageNavStudy1D-v0", entry_point="cage_sim.env:Study1DEnv")


_register()
