"""rclpy.timer: periodic callbacks, run by the executor in the spinning thread.

A node's timers follow the node's clock, as in rclpy: the steady clock normally, and ROS time from
`/clock` when the node has `use_sim_time` (then a timer fires when sim time passes its deadline; the
executor is woken by the `/clock` messages themselves).  Switching `use_sim_time` restarts the period.
"""

from __future__ import annotations

import time
from typing import Any, Callable, Optional


class Timer:
    """Created with `Node.create_timer(timer_period_sec, callback)`.

    Deadlines advance by whole periods from the start (no drift); when the executor falls behind by more
    than a period, missed periods are skipped rather than fired in a burst (rcl behaves the same).
    """

    def __init__(self, callback: Optional[Callable[[], Any]], timer_period_ns: int,
                 autostart: bool = True, clock: Any = None) -> None:
        if timer_period_ns < 0:
            raise ValueError('timer period must not be negative')
        self.callback = callback
        self._period_ns = int(timer_period_ns)
        self._canceled = not autostart
        self._clock = clock
        self._sim = self._uses_sim_time()
        now = self._now()
        self._last_call_ns = now
        self._next_call_ns = now + self._period_ns
        self._destroyed = False

    def _uses_sim_time(self) -> bool:
        return bool(getattr(self._clock, 'ros_time_is_active', False))

    def _now(self) -> int:
        return self._clock.now().nanoseconds if self._sim else time.monotonic_ns()

    @property
    def clock(self) -> Any:
        return self._clock

    def _sim_due(self) -> Optional[bool]:
        """For a sim-time timer: is it due now?  None for a steady-clock timer (see _next_deadline)."""
        sim = self._uses_sim_time()
        if sim != self._sim:  # use_sim_time switched: restart the period on the new time base
            self._sim = sim
            self.reset() if not self._canceled else None
        if not sim or self._canceled or self._destroyed:
            return None if not sim else False
        return self._now() >= self._next_call_ns

    @property
    def timer_period_ns(self) -> int:
        return self._period_ns

    @timer_period_ns.setter
    def timer_period_ns(self, value: int) -> None:
        self._period_ns = int(value)
        self.reset()

    def is_ready(self) -> bool:
        return not self._canceled and not self._destroyed and self._now() >= self._next_call_ns

    def is_canceled(self) -> bool:
        return self._canceled

    def cancel(self) -> None:
        self._canceled = True

    def reset(self) -> None:
        self._canceled = False
        now = self._now()
        self._last_call_ns = now
        self._next_call_ns = now + self._period_ns

    def time_since_last_call(self) -> int:
        return self._now() - self._last_call_ns

    def time_until_next_call(self) -> Optional[int]:
        if self._canceled or self._destroyed:
            return None
        return self._next_call_ns - self._now()

    def _next_deadline(self) -> Optional[int]:
        """Steady-clock deadline (None for canceled timers and for sim-time timers)."""
        if self._canceled or self._destroyed or self._sim:
            return None
        return self._next_call_ns

    def _fire(self) -> None:
        """Advance the deadline, then run the callback (rcl_timer_call semantics)."""
        now = self._now()
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
