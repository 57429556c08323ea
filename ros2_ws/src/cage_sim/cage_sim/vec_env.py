"""``CageNavVecEnv``: many cage missions stepped together, a ``gymnasium.vector.VectorEnv``.

Why a vector env of its own rather than ``SyncVectorEnv(CageNavEnv x n)``: the sonar is the costly
part of a step, and here one batched sonar call (numba, every mission in its own world) serves all
missions at once. Why a real ``VectorEnv``: so gymnasium's vector wrappers (episode statistics,
observation normalisation, action clipping, ...) and RL libraries that speak the gymnasium vector API
work on it unchanged.

Autoreset: gymnasium's ``SAME_STEP`` mode (``metadata["autoreset_mode"]``). A mission that ends in a
step is replaced by a fresh one in that same step: the returned observation is the new episode's
first, the finished episode's last observation is ``infos["final_obs"][i]`` and its info
``infos["final_info"]`` (gymnasium's layout: per-key arrays with ``_key`` masks, e.g.
``infos["_final_obs"]`` says which envs finished). Per-step infos: ``outcome`` (None while running;
``goal``, ``collision``, ``wander``, ``timeout``), ``is_success`` (outcome == goal) and ``steps``.
Terminated = goal, collision, wander; truncated = timeout (bootstrap it).
``autoreset_mode="next_step"`` gives gymnasium's other convention instead (the step after an
episode's end resets that env and returns its first observation, reward 0, not done): gymnasium's
observation wrappers (e.g. ``NormalizeObservation``) accept only that mode (or DISABLED).

Seeding: each env draws its scenarios from its own generator, spawned from one ``SeedSequence``;
``reset(seed=s)`` re-spawns them, so a seed fixes every episode of every env.

``replay``: an object with ``offer(scenario, outcome, tries)`` and ``draw() -> (scenario, tries) |
None`` (the trainer's ``HardCaseReplay``) is offered every finished mission and may hand back a
failed one to fly again instead of a fresh draw.

``action_filter``: a callable ``(actions, obs, missions) -> (flown actions, replaced flags)`` (the
trainer's ``driver.ShieldFilter``) that every step's actions pass through, given the observation
they were chosen on; ``infos["shielded"]`` then holds its flags (the shield: which proposals it
replaced as unsafe).
"""
from __future__ import annotations

from typing import Any, Sequence

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from .env import ACTION_SPACE, WaypointFn, observation_space
from .env import _prepare as prepare
from .mission import EnvConfig, Mission, observe_batch
from .scenarios import scenario_sampler

TERMINAL = ("goal", "collision", "wander")


class RngStates:
    """Checkpointing of per-env generators ``self.rngs`` (what the trainer saves and restores)."""

    rngs: list[np.random.Generator]

    def rng_states(self) -> list[dict]:
        """Every env's scenario generator state, in env order."""
        return [r.bit_generator.state for r in self.rngs]

    def set_rng_states(self, states: Sequence[dict]) -> None:
        if len(states) != len(self.rngs):
            raise ValueError(f"expected {len(self.rngs)} generator states, got {len(states)}")
        for r, st in zip(self.rngs, states):
            r.bit_generator.state = st


class CageNavVecEnv(RngStates, VectorEnv):
    """``n_envs`` missions stepped together; one batched sonar call per step (see the module doc)."""

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": []}

    def __init__(self, n_envs: int, scenario: Any = "cage", config: EnvConfig | None = None,
                 waypoint_fn: WaypointFn | None = None, seed: int = 0,
                 autoreset_mode: str | AutoresetMode = AutoresetMode.SAME_STEP, replay: Any = None,
                 action_filter: Any = None):
        if int(n_envs) < 1:
            raise ValueError(f"n_envs: must be >= 1, got {n_envs}")
        names = {"same_step": AutoresetMode.SAME_STEP, "next_step": AutoresetMode.NEXT_STEP}
        mode = names.get(autoreset_mode, autoreset_mode) if isinstance(autoreset_mode, str) else autoreset_mode
        if mode not in names.values():
            raise ValueError(f"autoreset_mode: same_step or next_step, got {autoreset_mode!r}")
        self.metadata = {**self.metadata, "autoreset_mode": mode}
        self._pending = np.zeros(int(n_envs), dtype=bool)     # next_step: envs to reset in this step
        self.num_envs = int(n_envs)
        self.config = config or EnvConfig()
        self.sampler = scenario_sampler(scenario)
        self.waypoint_fn = waypoint_fn
        self.single_observation_space = observation_space(self.config)
        self.single_action_space = ACTION_SPACE
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.render_mode = None
        self.replay = replay
        self.action_filter = action_filter
        self._obs: np.ndarray | None = None                   # the last observation returned (the filter's)
        self._tries = np.ones(self.num_envs, dtype=int)       # times each env's mission has been flown
        self._seed(seed)
        self.missions: list[Mission] = []

    @property
    def n_envs(self) -> int:
        """The trainer's name for ``num_envs``."""
        return self.num_envs

    def _seed(self, seed: int | Sequence[int] | None) -> None:
        if isinstance(seed, (list, tuple, np.ndarray)):
            if len(seed) != self.num_envs:
                raise ValueError(f"seed: expected {self.num_envs} seeds, got {len(seed)}")
            self.rngs = [np.random.default_rng(s if isinstance(s, np.random.SeedSequence) else int(s)) for s in seed]
        else:
            seq = np.random.SeedSequence(None if seed is None else int(seed))
            self.rngs = [np.random.default_rng(s) for s in seq.spawn(self.num_envs)]

    def reset(self, *, seed: "int | Sequence[int | np.random.SeedSequence] | None" = None, options: dict | None = None):
        """Start a fresh mission in every env; ``seed`` re-seeds their scenario generators."""
        if seed is not None:
            self._seed(seed)
        self.missions = [self._new_mission(i) for i in range(self.num_envs)]
        self._pending[:] = False
        obs = self._observe(range(self.num_envs))
        if self.action_filter is not None:     # the observation the next actions are chosen on
            self._obs = obs.copy()
        return obs, self._step_infos([None] * self.num_envs, np.zeros(self.num_envs, dtype=bool))

    def _new_mission(self, i: int) -> Mission:
        """Env ``i``'s next mission: a failed one to fly again (``replay``) or a fresh draw."""
        again = self.replay.draw() if self.replay is not None else None
        if again is not None:
            sc, self._tries[i] = again
        else:
            sc, self._tries[i] = prepare(self.sampler, self.rngs[i], self.waypoint_fn), 1
        return Mission(sc, self.config)

    def _ended(self, i: int, outcome: str) -> None:
        if self.replay is not None:
            self.replay.offer(self.missions[i].scenario, outcome, int(self._tries[i]))

    def _observe(self, idx) -> np.ndarray:
        return observe_batch(self.config, [self.missions[i] for i in idx], self.rngs[0])

    def _step_infos(self, outcomes: list[str | None], shielded: np.ndarray) -> dict[str, Any]:
        ones = np.ones(self.num_envs, dtype=bool)
        infos = {"outcome": np.array(outcomes, dtype=object), "_outcome": ones,
                 "is_success": np.array([o == "goal" for o in outcomes]), "_is_success": ones,
                 "steps": np.array([m.steps for m in self.missions]), "_steps": ones}
        if self.action_filter is not None:
            infos.update(shielded=shielded, _shielded=ones)
        return infos

    def step(self, actions: np.ndarray):
        if not self.missions:
            raise RuntimeError("call reset() before step()")
        actions = np.clip(np.asarray(actions, dtype=np.float64).reshape(self.num_envs), -1.0, 1.0)
        shielded = np.zeros(self.num_envs, dtype=bool)
        if self.action_filter is not None:
            actions, shielded = self.action_filter(actions, self._obs, self.missions)
            actions = np.clip(np.asarray(actions, dtype=np.float64).reshape(self.num_envs), -1.0, 1.0)
            shielded = np.asarray(shielded, dtype=bool).reshape(self.num_envs)
        rewards = np.empty(self.num_envs)
        outcomes: list[str | None] = [None] * self.num_envs
        for i, (m, a) in enumerate(zip(self.missions, actions)):
            if self._pending[i]:    # next_step mode: this step only starts the new episode
                self.missions[i] = self._new_mission(i)
                rewards[i] = 0.0
            else:
                rewards[i], outcomes[i] = m.step(float(a))
                if outcomes[i] is not None:
                    self._ended(i, outcomes[i])
        terminated = np.array([o in TERMINAL for o in outcomes])
        truncated = np.array([o == "timeout" for o in outcomes])
        obs = self._observe(range(self.num_envs))
        infos = self._step_infos(outcomes, shielded)
        done = np.flatnonzero(terminated | truncated)
        if self.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP:
            self._pending = terminated | truncated
        elif len(done):
            final_obs = np.full(self.num_envs, None, dtype=object)
            final_info: dict[str, Any] = {}
            for i in done:
                final_obs[i] = obs[i].copy()
                final_info = self._add_info(final_info, {**self.missions[i].info(),
                                                         "is_success": outcomes[i] == "goal"}, int(i))
                self.missions[i] = self._new_mission(i)
            infos.update(final_obs=final_obs, _final_obs=terminated | truncated, final_info=final_info,
                         _final_info=terminated | truncated)
            obs[done] = self._observe(done)
        if self.action_filter is not None:     # the observation the next actions are chosen on
            self._obs = obs.copy()
        return obs, rewards, terminated, truncated, infos


def finished(infos: dict[str, Any]) -> list[tuple[int, np.ndarray]]:
    """``(env index, last observation)`` of the episodes that ended in this step, from either
    gymnasium's SAME_STEP layout (object array + ``_final_obs`` mask) or a plain ``{i: obs}`` dict."""
    fo = infos.get("final_obs")
    if fo is None:
        return []
    if isinstance(fo, dict):
        return [(int(i), o) for i, o in fo.items()]
    mask = infos.get("_final_obs", np.array([o is not None for o in fo]))
    return [(int(i), fo[i]) for i in np.flatnonzero(mask)]
