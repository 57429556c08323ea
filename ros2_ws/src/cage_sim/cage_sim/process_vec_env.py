"""``ProcessVecEnv``: a ``CageNavVecEnv`` split over worker processes, so training uses every core.

Why: one trainer process steps its missions and then updates its networks, one core at a time;
on a 2-core machine the other core idles. Here each worker process owns a ``CageNavVecEnv`` with
its share of the envs (missions, sonar heads, memories) and, optionally, a ``labeller`` (the
expert, ``driver.ObservationLabeller`` or ``FlownLabeller``: its actions on each returned
observation come back with it, so the expert's rollouts also run in the workers). The parent sends actions, the workers step at the same time,
the parent merges their answers in env order: the same gymnasium vector API (SAME_STEP autoreset,
``final_obs`` / ``final_info``) as ``CageNavVecEnv``. ``step_async(actions)`` / ``step_wait()``
split a step (gymnasium's ``AsyncVectorEnv`` names) so the caller can work while the workers fly
it: the trainer runs that step's network updates there.

Seeding: env ``i`` draws its scenarios from the ``i``-th child of ``SeedSequence(seed)``, as in one
``CageNavVecEnv``; each worker's sonar noise comes from its first env's generator (in one process
it is env 0's), so a run is reproducible for a given number of workers, and runs with different
numbers of workers differ (noise and the scenarios of each worker's first env).

Workers are forked (Linux; they inherit the scenario sampler and route function, closures that
cannot be pickled); they are daemons, so they end with the parent, and ``close()`` ends them early.

Hard-case replay across processes: the pool (``replay``, the trainer's ``HardCaseReplay``) stays
in the parent, one pool for every env as in one process. Each worker's env has a ``ReplayRelay``
in its place: it reports every mission that ended (the scenario only for the outcomes the pool
keeps) with the step's answer, and flies the missions the parent sent back before a fresh draw.
The parent offers each report to the pool and draws once per ended mission, as ``CageNavVecEnv``
does; a drawn mission goes to the worker it came from with the next step and starts there at that
worker's next mission end: one mission end later than in one process, the share of re-flown
episodes the same.
"""
from __future__ import annotations

import multiprocessing as mp
from collections import deque
from typing import Any, Callable, Sequence

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from .env import ACTION_SPACE, observation_space
from .mission import EnvConfig
from .vec_env import CageNavVecEnv, finished

WORKER_GONE = "an env worker process ended unexpectedly (see its traceback above)"


def env_info(infos: dict[str, Any], j: int) -> dict[str, Any]:
    """Env ``j``'s part of a gymnasium vector ``infos`` (the keys its ``_key`` masks set for it)."""
    out: dict[str, Any] = {}
    for k, v in infos.items():
        if k.startswith("_"):
            continue
        mask = infos.get(f"_{k}")
        if mask is not None and not mask[j]:
            continue
        out[k] = env_info(v, j) if isinstance(v, dict) else v[j]
    return out


class ReplayRelay:
    """A worker's stand-in for the parent's hard-case replay pool (see the module doc): what
    ``CageNavVecEnv`` offers goes out with the next answer, what the parent drew comes in."""

    def __init__(self, keep: Sequence[str] | None = None):
        self.keep = None if keep is None else tuple(keep)   # outcomes whose scenario the pool may keep
        self.inbox: deque = deque()          # (scenario, tries) to fly next, oldest first
        self.outbox: list = []               # (scenario or None, outcome, tries) since the last answer

    def offer(self, scenario: Any, outcome: str, tries: int) -> None:
        wanted = self.keep is None or outcome in self.keep
        self.outbox.append((scenario if wanted else None, outcome, tries))

    def draw(self) -> tuple[Any, int] | None:
        return self.inbox.popleft() if self.inbox else None

    def exchange(self, incoming: Sequence[tuple[Any, int]]) -> list:
        """Take the parent's drawn missions; hand over the reports gathered since the last call."""
        self.inbox.extend(incoming)
        out, self.outbox = self.outbox, []
        return out


def _worker(conn, make: Callable[[], CageNavVecEnv], labeller) -> None:
    """One worker's loop: build its env, then answer commands until ``close`` (or the pipe ends)."""
    env = make()

    def labels(obs, infos):
        return None if labeller is None else labeller(obs, env.missions, finished(infos))

    def relay(incoming) -> list:
        return env.replay.exchange(incoming) if env.replay is not None else []

    try:
        while True:
            cmd, arg = conn.recv()
            if cmd == "reset":
                obs, infos = env.reset(seed=arg)
                conn.send((obs, infos, labels(obs, infos)))
            elif cmd == "step":
                actions, incoming = arg
                relay(incoming)                   # before the step: a mission ending in it may fly one
                obs, rew, term, trunc, infos = env.step(actions)
                conn.send((obs, rew, term, trunc, infos, labels(obs, infos), relay(())))
            elif cmd == "rng_states":
                conn.send(env.rng_states())
            elif cmd == "set_rng_states":
                env.set_rng_states(arg)
                conn.send(None)
            elif cmd == "close":
                break
    except (EOFError, KeyboardInterrupt):
        pass
    finally:
        conn.close()


class ProcessVecEnv(VectorEnv):
    """``n_envs`` missions over ``n_workers`` forked processes (``CageNavVecEnv``'s arguments; the
    ``replay`` pool stays here, see the module doc), plus ``labeller``: ``driver.ObservationLabeller``
    or ``FlownLabeller``, run in the workers on every returned observation with the worker's
    missions; its actions in ``infos["labels"]`` and, for the episodes that ended, on their last
    observation in ``infos["final_labels"]`` (NaN elsewhere), each a (n_envs, 1) array), and
    ``action_filter`` (``CageNavVecEnv``'s; each worker gets its own copy, for its own missions)."""

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": []}

    def __init__(self, n_envs: int, n_workers: int, scenario: Any = "cage", config=None, waypoint_fn=None,
                 seed: int = 0, labeller=None, replay: Any = None, action_filter: Any = None):
        n_envs, n_workers = int(n_envs), int(n_workers)
        if not 1 <= n_workers <= n_envs:
            raise ValueError(f"env_workers: must be between 1 and n_envs ({n_envs}), got {n_workers}")
        if "fork" not in mp.get_all_start_methods():
            raise RuntimeError("env_workers > 1 needs the 'fork' start method (Linux)")
        self.num_envs = n_envs
        self.slices = np.array_split(np.arange(n_envs), n_workers)
        ctx = mp.get_context("fork")
        self._conns, self._procs = [], []
        self.config = config or EnvConfig()
        self.single_observation_space, self.single_action_space = observation_space(self.config), ACTION_SPACE
        self.observation_space = batch_space(self.single_observation_space, n_envs)
        self.action_space = batch_space(self.single_action_space, n_envs)
        self.render_mode = None
        self.labels_on = labeller is not None
        self._waiting = False
        self.replay = replay
        self._drawn: list[list] = [[] for _ in self.slices]    # replay missions to send, per worker
        keep = getattr(replay, "outcomes", None)     # None: every ended mission's scenario comes back
        seeds = self._seeds(seed)
        for idx in self.slices:
            parent, child = ctx.Pipe()
            part = [seeds[i] for i in idx]

            def make(n=len(idx), part=part):
                relay = ReplayRelay(keep) if replay is not None else None
                return CageNavVecEnv(n, scenario, self.config, waypoint_fn, seed=part, replay=relay,
                                     action_filter=action_filter)
            p = ctx.Process(target=_worker, args=(child, make, labeller), daemon=True)
            p.start()
            child.close()
            self._conns.append(parent)
            self._procs.append(p)
        self.closed = False

    @property
    def n_envs(self) -> int:
        return self.num_envs

    def _seeds(self, seed: int | None) -> list[np.random.SeedSequence]:
        return np.random.SeedSequence(None if seed is None else int(seed)).spawn(self.num_envs)

    def _send(self, cmds: Sequence[tuple[str, Any]]) -> None:
        try:
            for conn, cmd in zip(self._conns, cmds):
                conn.send(cmd)
        except OSError:                    # BrokenPipeError: the worker is gone
            raise RuntimeError(WORKER_GONE) from None

    def _receive(self) -> list:
        try:
            return [conn.recv() for conn in self._conns]
        except (EOFError, OSError):
            raise RuntimeError(WORKER_GONE) from None

    def _ask_async(self, cmds: Sequence[tuple[str, Any]]) -> None:
        if self._waiting:
            raise RuntimeError("step_wait() first: a step is in flight")
        self._send(cmds)
        self._waiting = True

    def _ask(self, cmds: Sequence[tuple[str, Any]]) -> list:
        self._ask_async(cmds)
        self._waiting = False
        return self._receive()

    def _merge(self, parts: list[dict], labels: list) -> dict[str, Any]:
        """The workers' vector infos as one: keys every env of every worker has (``outcome``,
        ``steps``, ...) concatenated, dtypes kept; the others (``final_obs``, ``final_info``) env by
        env with gymnasium's ``_add_info``, as one ``CageNavVecEnv`` builds them."""
        infos: dict[str, Any] = {}
        full = [k for k in parts[0] if not k.startswith("_") and not isinstance(parts[0][k], dict)
                and all(k in p and np.all(p.get(f"_{k}", True)) for p in parts)]
        for k in full:
            infos[k] = np.concatenate([p[k] for p in parts])
            if f"_{k}" in parts[0]:
                infos[f"_{k}"] = np.ones(self.num_envs, dtype=bool)
        skip = set(full) | {f"_{k}" for k in full}
        for idx, part in zip(self.slices, parts):
            rest = {k: v for k, v in part.items() if k not in skip}
            for j, i in enumerate(idx):
                infos = self._add_info(infos, env_info(rest, j), int(i))
        if self.labels_on:
            infos["labels"] = np.concatenate([lab[0] for lab in labels])
            infos["final_labels"] = np.concatenate([lab[1] for lab in labels])
        return infos

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        seeds = self._seeds(seed) if seed is not None else None
        out = self._ask([("reset", None if seeds is None else [seeds[i] for i in idx]) for idx in self.slices])
        obs = np.concatenate([o[0] for o in out])
        return obs, self._merge([o[1] for o in out], [o[2] for o in out])

    def step(self, actions: np.ndarray):
        self.step_async(actions)
        return self.step_wait()

    def step_async(self, actions: np.ndarray) -> None:
        """Send this step's actions and return at once: the workers fly it while the caller does
        something else (the trainer: its network updates); ``step_wait()`` collects the answer."""
        a = np.asarray(actions, dtype=np.float64).reshape(self.num_envs)
        self._ask_async([("step", (a[idx], drawn)) for idx, drawn in zip(self.slices, self._drawn)])
        self._drawn = [[] for _ in self.slices]

    def step_wait(self):
        if not self._waiting:
            raise RuntimeError("step_wait() without step_async()")
        self._waiting = False
        out = self._receive()
        for w, o in enumerate(out):
            self._pool(w, o[6])
        obs, rew, term, trunc = (np.concatenate([o[k] for o in out]) for k in range(4))
        return obs, rew, term, trunc, self._merge([o[4] for o in out], [o[5] for o in out])

    def _pool(self, w: int, reports: list) -> None:
        """Worker ``w``'s ended missions to the replay pool; one draw each, as in one process."""
        for scenario, outcome, tries in reports:
            self.replay.offer(scenario, outcome, tries)
            again = self.replay.draw()
            if again is not None:
                self._drawn[w].append(again)

    def rng_states(self) -> list[dict]:
        """Every env's scenario generator state, in env order (the trainer's checkpoint)."""
        return [s for part in self._ask([("rng_states", None)] * len(self._conns)) for s in part]

    def set_rng_states(self, states: Sequence[dict]) -> None:
        if len(states) != self.num_envs:
            raise ValueError(f"expected {self.num_envs} generator states, got {len(states)}")
        self._ask([("set_rng_states", [states[i] for i in idx]) for idx in self.slices])

    def close(self, **kwargs: Any) -> None:
        if self.closed:
            return
        for conn in self._conns:
            try:
                conn.send(("close", None))
            except (BrokenPipeError, OSError):
                pass
        for p in self._procs:
            p.join(timeout=5)
            if p.is_alive():
                p.terminate()
        for conn in self._conns:
            conn.close()
        self.closed = True
