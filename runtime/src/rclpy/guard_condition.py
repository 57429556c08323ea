"""rclpy.guard_condition: `node.create_guard_condition(callback)`; `trigger()` (from any thread) makes
the executor spinning the node run the callback once."""

from __future__ import annotations

from typing import Any, Callable, Optional


class GuardCondition:
    def __init__(self, callback: Optional[Callable[[], Any]], node: Any) -> None:
        self.callback = callback
        self._node = node
        self._destroyed = False

    def trigger(self) -> None:
        executor = self._node.executor
        if self._destroyed or executor is None or self.callback is None:
            return
        executor.create_task(self.callback)

    def destroy(self) -> None:
        self._destroyed = True

    def __enter__(self) -> 'GuardCondition':
        return self

    def __exit__(self, *exc: Any) -> None:
        self.destroy()
