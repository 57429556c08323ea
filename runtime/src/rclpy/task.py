"""rclpy.task: a minimal Future (enough for spin_until_future_complete with timers/subscriptions)."""

from __future__ import annotations

from typing import Any, Callable, List, Optional


class Future:
    def __init__(self, *, executor: Any = None) -> None:
        self._done = False
        self._cancelled = False
        self._result: Any = None
        self._exception: Optional[BaseException] = None
        self._callbacks: List[Callable[['Future'], None]] = []

    def done(self) -> bool:
        return self._done

    def cancelled(self) -> bool:
        return self._cancelled

    def cancel(self) -> None:
        if not self._done:
            self._cancelled = True
            self._set_done()

    def result(self) -> Any:
        if self._exception is not None:
            raise self._exception
        return self._result

    def exception(self) -> Optional[BaseException]:
        return self._exception

    def set_result(self, result: Any) -> None:
        self._result = result
        self._set_done()

    def set_exception(self, exception: BaseException) -> None:
        self._exception = exception
        self._set_done()

    def add_done_callback(self, callback: Callable[['Future'], None]) -> None:
        if self._done:
            callback(self)
        else:
            self._callbacks.append(callback)

    def _set_done(self) -> None:
        self._done = True
        callbacks, self._callbacks = self._callbacks, []
        for cb in callbacks:
            cb(self)
