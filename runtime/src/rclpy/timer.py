"""rclpy.timer: periodic callbacks on the steady clock, run by the executor in the spinning thread."""

from __future__ import annotations

import time
from typing import Any, Callable, Optional


class Timer:
    """Created with `Node.create_timer(timer_period_sec, callback)`.

    Deadlines advance by whole periods from the start (no drift); when the executor falls behind by more
    than a period, missed periods are skipped rather than fired in a burst (rcl behaves the same).
    """

    def __init__(self, callback: Optional[Callable[[], Any]], timer_period_ns: int,
                 autostart: bool = True) -> None:
        if timer_period_ns < 0:
            raise ValueError('timer period must not be negative')
        self.callback = callback
        self._period_ns = int(timer_period_ns)
        self._canceled = not autostart
        now = time.monotonic_ns()
        self._last_call_ns = now
        self._next_call_ns = now + self._period_ns
        self._destroyed = False

    @property
    def timer_period_ns(self) -> int:
        return self._period_ns

    @timer_period_ns.setter
    def timer_period_ns(self, value: int) -> None:
        self._period_ns = int(value)
        self.reset()

    def is_ready(self) -> bool:
        return not self._canceled and not self._destroyed and time.monotonic_ns() >= self._next_call_ns

    def is_canceled(self) -> bool:
        return self._canceled

    def cancel(self) -> None:
        self._canceled = True

    def reset(self) -> None:
        self._canceled = False
        now = time.monotonic_ns()
        self._last_call_ns = now
        self._next_call_ns = now + self._period_ns

    def time_since_last_call(self) -> int:
        return time.monotonic_ns() - self._last_call_ns

    def time_until_next_call(self) -> Optional[int]:
        if self._canceled or self._destroyed:
            return None
        return self._next_call_ns - time.monotonic_ns()

    def _next_deadline(self) -> Optional[int]:
        return None if (self._canceled or self._destroyed) else self._next_call_ns

    def _fire(self) -> None:
        """Advance the deadline, then run the callback (rcl_timer_call semantics)."""
        now = time.monotonic_ns()
        self._last_call_ns = now
        period = self._period_ns
        if period <= 0:
            self._next_call_ns = now
        else:
            self._next_call_ns += period
            if self._next_call_ns <= now:
                missed = (now - self._next_call_ns) // period + 1
                self._next_call_ns += missed * period
        if self.callback is not None:
            self.callback()

    def destroy(self) -> None:
        self._destroyed = True

    def __enter__(self) -> 'Timer':
        return self

    def __exit__(self, *exc: Any) -> None:
        self.destroy()
