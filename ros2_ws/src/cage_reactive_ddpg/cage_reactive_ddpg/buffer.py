"""Replay buffer (NumPy ring) and the n-step folding in front of it.

Each stored transition carries its own ``discount`` = gamma^k for the k rewards folded into it, or 0
when the episode terminated within them; so the TD target is always ``r + discount * Q'(s', mu'(s'))``
and 1-step (the study), n-step, terminations and time-limit truncations (bootstrapped, not terminal)
share one update rule.

A transition may also carry the expert's action for its observation (``expert``; NaN = none): what
the behaviour-cloning term of expert-guided training (``agent.DDPGAgent.update``) pulls the actor to.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np


@dataclass
class Batch:
    obs: np.ndarray
    act: np.ndarray
    rew: np.ndarray
    next_obs: np.ndarray
    discount: np.ndarray
    expert: np.ndarray | None = None      # (B, act_dim), NaN where no expert labelled the observation


class ReplayBuffer:
    def __init__(self, capacity: int, obs_dim: int, act_dim: int = 1):
        self.capacity, self.size, self.pos = int(capacity), 0, 0
        self.obs = np.zeros((self.capacity, obs_dim), np.float32)
        self.next_obs = np.zeros((self.capacity, obs_dim), np.float32)
        self.act = np.zeros((self.capacity, act_dim), np.float32)
        self.rew = np.zeros(self.capacity, np.float32)
        self.discount = np.zeros(self.capacity, np.float32)
        self.expert = np.full((self.capacity, act_dim), np.nan, np.float32)

    def add(self, obs, act, rew, next_obs, discount, expert=None) -> None:
        """Add one or a batch of transitions (leading dimension = batch); ``expert``: the expert's
        action(s) for ``obs`` (None or NaN: not labelled)."""
        obs = np.atleast_2d(obs)
        n = obs.shape[0]
        idx = (self.pos + np.arange(n)) % self.capacity
        self.obs[idx], self.next_obs[idx] = obs, np.atleast_2d(next_obs)
        self.act[idx] = np.asarray(act, np.float32).reshape(n, -1)
        self.rew[idx], self.discount[idx] = rew, discount
        self.expert[idx] = np.nan if expert is None else np.asarray(expert, np.float32).reshape(n, -1)
        self.pos = int((self.pos + n) % self.capacity)
        self.size = int(min(self.size + n, self.capacity))

    def sample(self, rng: np.random.Generator, batch_size: int) -> Batch:
        idx = rng.integers(0, self.size, batch_size)
        return Batch(self.obs[idx], self.act[idx], self.rew[idx], self.next_obs[idx], self.discount[idx],
                     self.expert[idx])

    def state(self) -> dict[str, np.ndarray]:
        n = self.size
        return {"obs": self.obs[:n], "next_obs": self.next_obs[:n], "act": self.act[:n],
                "rew": self.rew[:n], "discount": self.discount[:n], "expert": self.expert[:n],
                "meta": np.array([self.pos, self.size], np.int64)}

    def load_state(self, s: dict[str, np.ndarray]) -> None:
        n = min(int(s["meta"][1]), self.capacity)
        for k in ("obs", "next_obs", "act", "rew", "discount"):
            getattr(self, k)[:n] = s[k][:n]
        self.expert[:n] = s["expert"][:n] if "expert" in s else np.nan     # older buffers had no labels
        self.size, self.pos = n, int(s["meta"][0]) % self.capacity


class NStepFolder:
    """Per-env queues that turn 1-step transitions into n-step ones (n = 1 passes them through)."""

    def __init__(self, n_envs: int, n_step: int, gamma: float):
        self.n, self.gamma = n_step, gamma
        self.queues: list[deque] = [deque() for _ in range(n_envs)]

    def _fold(self, q: deque, next_obs, terminated: bool):
        obs0, act0, _, exp0 = q[0]
        ret, disc = 0.0, 1.0
        for _, _, r, _ in q:
            ret += disc * r
            disc *= self.gamma
        return obs0, act0, ret, next_obs, 0.0 if terminated else disc, exp0

    def push(self, i: int, obs, act, rew: float, next_obs, terminated: bool, done: bool,
             expert=None) -> list[tuple]:
        """Record env ``i``'s step; return the n-step transitions that are now complete
        (``ReplayBuffer.add`` arguments; the expert's action is that of the first observation)."""
        q = self.queues[i]
        q.append((obs, act, rew, expert))
        out = []
        if len(q) == self.n:
            out.append(self._fold(q, next_obs, terminated))
            q.popleft()
        if done:
            while q:
                out.append(self._fold(q, next_obs, terminated))
                q.popleft()
        return out

    def reset(self) -> None:
        for q in self.queues:
            q.clear()
