"""The study's 1D sanity case for the trainer: ``Study1DEnv`` batched behind the vec-env interface.

Why: the 1D case (start and goal in [0, 10], action = step) is the quickest check that the DDPG
machinery learns at all; the tests train on it for a few seconds.
"""
from __future__ import annotations

import numpy as np
from cage_sim.env import Study1DEnv
from cage_sim.vec_env import RngStates

STUDY1D = "study1d"


class Study1DVecEnv(RngStates):
    """``n_envs`` Study1DEnv stepped together, same-step autoreset like ``CageNavVecEnv``."""

    def __init__(self, n_envs: int, seed: int = 0):
        self.n_envs = n_envs
        self.envs = [Study1DEnv() for _ in range(n_envs)]
        seq = np.random.SeedSequence(seed)
        self.seeds = [int(s.generate_state(1)[0]) for s in seq.spawn(n_envs)]
        self.rngs = [np.random.default_rng(s) for s in self.seeds]   # checkpointed like CageNavVecEnv's

    def reset(self) -> np.ndarray:
        return np.stack([e.reset(seed=s)[0] for e, s in zip(self.envs, self.seeds)])

    def step(self, actions: np.ndarray):
        obs, rew = np.zeros((self.n_envs, 1), np.float32), np.zeros(self.n_envs)
        term, trunc = np.zeros(self.n_envs, bool), np.zeros(self.n_envs, bool)
        outcomes, final_obs = [None] * self.n_envs, {}
        for i, (e, a) in enumerate(zip(self.envs, np.asarray(actions).reshape(self.n_envs, -1))):
            obs[i], rew[i], term[i], trunc[i], info = e.step(a)
            outcomes[i] = info["outcome"]
            if term[i] or trunc[i]:
                final_obs[i] = obs[i].copy()
                obs[i] = e.reset()[0]
        infos = {"outcome": outcomes}
        if final_obs:
            infos["final_obs"] = final_obs
        return obs, rew, term, trunc, infos

    def close(self) -> None:
        """Nothing to release (the trainer closes every kind of vector env)."""


def evaluate_1d(policy, episodes: int, seed: int) -> dict:
    """Goal rate, mean reward and mean steps of a policy on seeded 1D episodes (the study: 3.84 steps)."""
    env = Study1DEnv()
    rewards, steps, goals = [], [], 0
    for i in range(episodes):
        obs, _ = env.reset(seed=seed + i)
        total = 0.0
        while True:
            obs, r, term, trunc, info = env.step(policy.act(obs))
            total += r
            if term or trunc:
                break
        rewards.append(total)
        steps.append(info["steps"])
        goals += info["outcome"] == "goal"
    n = max(episodes, 1)
    return {"episodes": episodes, "rates": {"goal": goals / n, "collision": 0.0, "wander": 0.0,
                                            "timeout": 1 - goals / n},
            "mean_reward": float(np.mean(rewards)), "mean_steps": float(np.mean(steps))}
