"""What the `ros2` verbs share: a hidden tool node that waits for discovery, one-line failures."""

from __future__ import annotations

import os
import sys
import time
from typing import Any, Optional


def fail(message: str, code: int = 1) -> int:
    """Print one line to stderr and return the exit status (never a traceback)."""
    print(message, file=sys.stderr, flush=True)
    return code


def hidden(name: str) -> bool:
    """ROS hides names with a token starting with '_' (e.g. `/fibonacci/_action/send_goal`)."""
    return any(token.startswith('_') for token in name.split('/') if token)


class Tool:
    """An rclpy context with a hidden node `_ros2cli_<pid>` that has listened for `spin_time` seconds.

    Without a ros2 daemon the graph is only known after discovery; ros2cli waits `--spin-time` too.
    """

    def __init__(self, spin_time: float = 0.0) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.node import Node
        from rclpy.signals import SignalHandlerOptions
        self.context = Context()
        rclpy.init(args=[], context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        self.node = Node(f'_ros2cli_{os.getpid()}', context=self.context, start_parameter_services=False,
                         enable_rosout=False)
        self._observer = self.node._observer()  # noqa: SLF001
        if spin_time > 0:
            time.sleep(spin_time)

    def observer(self) -> Any:
        return self._observer

    def executor(self) -> Any:
        from rclpy.executors import SingleThreadedExecutor
        executor = SingleThreadedExecutor(context=self.context)
        executor.add_node(self.node)
        return executor

    def spin_until(self, executor: Any, done: Any, timeout: Optional[float]) -> bool:
        """Spin until `done()`; False at the timeout (None: no timeout) or on Ctrl-C."""
        deadline = None if timeout is None else time.monotonic() + timeout
        try:
            while self.context.ok() and not done():
                remaining = None if deadline is None else deadline - time.monotonic()
                if remaining is not None and remaining <= 0:
                    return False
                executor.spin_once(timeout_sec=0.1 if remaining is None else min(remaining, 0.1))
        except KeyboardInterrupt:
            return False
        return bool(done())

    def close(self) -> None:
        try:
            self.node.destroy_node()
        finally:
            self.context.try_shutdown()

    def __enter__(self) -> 'Tool':
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
