"""rclpy.rate: sleep at a fixed frequency (wall clock, steady), ending early on shutdown."""

from __future__ import annotations

import time
from typing import Any


class Rate:
    def __init__(self, frequency: float, *, context: Any = None) -> None:
        if frequency <= 0:
            raise ValueError('frequency must be > 0')
        self._period = 1.0 / frequency
        self._next = time.monotonic() + self._period
        self._context = context
        self._destroyed = False

    def sleep(self) -> None:
        from rclpy.exceptions import ROSInterruptException
        while True:
            if self._destroyed or (self._context is not None and not self._context.ok()):
                raise ROSInterruptException()
            remaining = self._next - time.monotonic()
            if remaining <= 0:
                break
            time.sleep(min(remaining, 0.05))
        self._next += self._period
        now = time.monotonic()
        if self._next < now:
            self._next = now + self._period

    def destroy(self) -> None:
        self._destroyed = True
