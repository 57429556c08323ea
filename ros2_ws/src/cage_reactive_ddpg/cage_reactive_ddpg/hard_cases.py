"""Hard-case replay: fly the missions the policy failed again, so their rare situations are learnt.

Why: the raw policies collide in a few percent of sea missions, each time in a situation (a small
obstacle met late in a strong current, a school closing in near the net) that the training stream
brings up once in hundreds of episodes; the replay buffer holds a handful of such transitions among
hundreds of thousands. Oversampling a whole family (``sea_hard``) raises their share only a little.
Re-flying the very missions that failed (same layout, current, schools and route, new exploration
noise) puts the policy back where it went wrong until it gets through, as prioritised level replay
(Jiang et al. 2021) does with whole levels.

``CageNavVecEnv(..., replay=HardCaseReplay(...))`` offers every finished mission; a failed one
(outcome in ``outcomes``) is kept, and each new episode is a kept mission with probability
``fraction`` (the oldest first), otherwise a fresh draw. A mission is re-flown at most ``max_tries``
times (one the policy cannot solve does not take over the stream), and at most ``capacity`` wait.
Its own generator: with replay off the training streams are unchanged.
"""
from __future__ import annotations

from collections import deque

import numpy as np
from cage_sim.scenarios import Scenario

FAILED = ("collision", "timeout", "wander")


class HardCaseReplay:
    """Failed missions waiting to be flown again (see the module doc)."""

    def __init__(self, fraction: float, max_tries: int = 3, capacity: int = 1000,
                 outcomes: tuple[str, ...] = FAILED, seed: int = 0):
        if not 0.0 <= fraction <= 1.0:
            raise ValueError(f"replay_fraction: must be in [0, 1], got {fraction!r}")
        if max_tries < 1 or capacity < 1:
            raise ValueError(f"replay: max_tries ({max_tries}) and capacity ({capacity}) must be >= 1")
        bad = sorted(set(outcomes) - set(FAILED))
        if bad:
            raise ValueError(f"replay outcomes: {bad} are not failures ({', '.join(FAILED)})")
        self.fraction, self.max_tries, self.outcomes = float(fraction), int(max_tries), tuple(outcomes)
        self.queue: deque[tuple[Scenario, int]] = deque(maxlen=int(capacity))
        self.rng = np.random.default_rng([seed, 0x4EA1])
        self.offered = self.kept = self.replayed = 0

    def offer(self, scenario: Scenario, outcome: str, tries: int) -> None:
        """A mission ended with ``outcome`` after being flown ``tries`` times (1 = a fresh draw)."""
        self.offered += 1
        if outcome in self.outcomes and tries < self.max_tries:
            self.queue.append((scenario, tries))
            self.kept += 1

    def draw(self) -> tuple[Scenario, int] | None:
        """(a failed mission to fly again, the try it will be) or None: draw a fresh one."""
        if not self.queue or self.rng.random() >= self.fraction:
            return None
        scenario, tries = self.queue.popleft()
        self.replayed += 1
        return scenario, tries + 1

    def stats(self) -> dict[str, int]:
        return {"offered": self.offered, "kept": self.kept, "replayed": self.replayed, "waiting": len(self.queue)}
