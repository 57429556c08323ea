"""rclpy.task: Future (awaitable, thread-safe completion) and Task (a callback or coroutine run by an executor).

Why tasks: rclpy lets service callbacks and action execute callbacks be coroutines that `await` futures
(a service reply, a goal result).  A Task runs its coroutine step by step in the executor's thread; when
the coroutine awaits a Future that is not done, the task is re-queued by that future's done callback, so
nothing polls.
"""

from __future__ import annotations

import inspect
import threading
from typing import Any, Callable, Generator, List, Optional


class Future:
    """Represents the outcome of a task in the future (rclpy.task.Future)."""

    def __init__(self, *, executor: Any = None) -> None:
        self._lock = threading.RLock()
        self._done = False
        self._cancelled = False
        self._result: Any = None
        self._exception: Optional[BaseException] = None
        self._callbacks: List[Callable[['Future'], None]] = []
        self._event = threading.Event()
        self._executor = executor

    def __await__(self) -> Generator['Future', None, Any]:
        while not self._done:
            yield self
        return self.result()

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
        with self._lock:
            if not self._done:
                self._callbacks.append(callback)
                return
        callback(self)

    def _wait(self, timeout: Optional[float]) -> bool:
        """Block the calling thread until done (used by Client.call from a non-spinning thread)."""
        return self._event.wait(timeout)

    def _set_done(self) -> None:
        with self._lock:
            if self._done:
                return
            self._done = True
            callbacks, self._callbacks = self._callbacks, []
        self._event.set()
        for cb in callbacks:
            cb(self)


class Task(Future):
    """A callback (plain function or coroutine function) run by an executor; its return value is the
    task's result (rclpy.task.Task)."""

    def __init__(self, handler: Callable[..., Any], args: Any = None, kwargs: Any = None,
                 executor: Any = None) -> None:
        super().__init__(executor=executor)
        self._handler: Any = handler
        self._args = args or ()
        self._kwargs = kwargs or {}
        self._executing = False
        self._coro: Any = None

    def executing(self) -> bool:
        return self._executing

    def __call__(self) -> None:
        """Run the handler, or the coroutine up to its next suspension; re-queued when it can go on."""
        if self._done or self._executing:
            return
        self._executing = True
        try:
            if self._coro is None:
                out = self._handler(*self._args, **self._kwargs)
                if not inspect.iscoroutine(out):
                    self.set_result(out)
                    return
                self._coro = out
            try:
                awaited = self._coro.send(None)
            except StopIteration as stop:
                self.set_result(stop.value)
                return
            self._suspend_on(awaited)
        except Exception as exc:  # noqa: BLE001 - the exception is the task's outcome, as in rclpy
            self.set_exception(exc)
        finally:
            self._executing = False

    def _suspend_on(self, awaited: Any) -> None:
        executor = self._executor
        if executor is None:
            return
        if isinstance(awaited, Future) and not awaited.done():
            awaited.add_done_callback(lambda _f: executor._requeue(self))  # noqa: SLF001
        else:
            executor._requeue(self)  # noqa: SLF001
