"""rclpy.utilities: the default context and process-wide helpers."""

from __future__ import annotations

import sys
import threading
from typing import List, Optional

from rclpy.context import Context

_default_context = Context()
_lock = threading.Lock()


def get_default_context(*, shutting_down: bool = False) -> Context:
    return _default_context


def ok(*, context: Optional[Context] = None) -> bool:
    return (context or _default_context).ok()


def shutdown(*, context: Optional[Context] = None, uninstall_handlers: Optional[bool] = None) -> None:
    (context or _default_context).shutdown()


def try_shutdown(*, context: Optional[Context] = None,
                 uninstall_handlers: Optional[bool] = None) -> None:
    (context or _default_context).try_shutdown()


def get_rmw_implementation_identifier() -> str:
    """The wire protocol this runtime speaks (it interoperates with rmw_cyclonedds_cpp)."""
    return 'rmw_cyclonedds_cpp'


def remove_ros_args(args: Optional[List[str]] = None) -> List[str]:
    """`args` (default sys.argv) without the `--ros-args ... [--]` sections."""
    from cage_ros_runtime.arguments import split_ros_args
    return split_ros_args(list(sys.argv if args is None else args))[1]


def timeout_sec_to_nsec(timeout_sec: Optional[float]) -> int:
    if timeout_sec is None or timeout_sec < 0:
        return -1
    return int(float(timeout_sec) * 1e9)
