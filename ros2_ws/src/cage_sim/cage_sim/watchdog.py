"""Noticing a silent peer (pure; no ROS import).

The equivalent of DDS liveliness/deadline QoS at the level the nodes care about: a node records when it
last heard a peer and asks, on its own timer, whether the peer has been quiet too long. It says so once
when the peer falls silent and once when it speaks again, so a dead node costs one log line, not one
per tick. The clock is the caller's: simulation nanoseconds where the decision clock runs (so a time
scale of 20x does not stretch the blind distance), wall seconds where it stands (lockstep waiting).
"""
from __future__ import annotations


class Silence:
    def __init__(self, timeout: float):
        if not timeout > 0:
            raise ValueError("a silence timeout must be > 0")
        self.timeout = timeout
        self.last: float | None = None
        self.silent = False

    def heard(self, now: float) -> bool:
        """Record a message; True when the peer was silent until now (it came back)."""
        self.last = now
        back, self.silent = self.silent, False
        return back

    def age(self, now: float) -> float:
        return 0.0 if self.last is None else now - self.last

    def check(self, now: float) -> float | None:
        """The silence so far when it just exceeded the timeout (once), else None. A peer never heard
        from is not silent: it has not started yet."""
        if self.last is None or self.silent or now - self.last <= self.timeout:
            return None
        self.silent = True
        return now - self.last
