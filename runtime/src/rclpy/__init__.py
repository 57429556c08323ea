"""rclpy for the cage runtime: the Jazzy rclpy API subset over Cyclone DDS (see runtime/README.md).

Installed only where no real rclpy exists; wire-compatible with rmw_cyclonedds_cpp.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, List, Optional

from rclpy.context import Context
from rclpy.signals import SignalHandlerOptions, install_signal_handlers, register_context
from rclpy.utilities import get_default_context, get_rmw_implementation_identifier, ok, \
    remove_ros_args, shutdown, try_shutdown

if TYPE_CHECKING:
    from rclpy.executors import Executor
    from rclpy.node import Node

__all__ = ['init', 'shutdown', 'try_shutdown', 'ok', 'spin', 'spin_once', 'spin_until_future_complete',
           'create_node', 'get_global_executor', 'get_default_context', 'remove_ros_args',
           'get_rmw_implementation_identifier', 'Context', 'SignalHandlerOptions']

_global_executor: Optional['Executor'] = None


def init(*, args: Optional[List[str]] = None, context: Optional[Context] = None,
         domain_id: Optional[int] = None,
         signal_handler_options: Optional[SignalHandlerOptions] = None) -> None:
    """Initialize a context (default: the global one) from `args` (default: sys.argv).

    Installs SIGINT/SIGTERM handlers (unless `signal_handler_options=SignalHandlerOptions.NO`).
    Malformed ROS arguments (`-p` without `:=`, a missing or broken `--params-file`, an unknown flag)
    end the process with one line naming the argument and exit status 2.
    """
    ctx = get_default_context() if context is None else context
    from cage_ros_runtime.arguments import RosArgumentError
    try:
        ctx.init(args, domain_id=domain_id)
    except RosArgumentError as exc:
        # real rclpy raises RCLError with a traceback; here a malformed command line is one line, exit 2
        import sys
        print(f'error: {exc}', file=sys.stderr, flush=True)
        raise SystemExit(2) from None
    register_context(ctx)
    install_signal_handlers(SignalHandlerOptions.ALL if signal_handler_options is None
                            else signal_handler_options)


def get_global_executor() -> 'Executor':
    global _global_executor
    if _global_executor is None:
        from rclpy.executors import SingleThreadedExecutor
        _global_executor = SingleThreadedExecutor()
        get_default_context().on_shutdown(_reset_global_executor)
    return _global_executor


def _reset_global_executor() -> None:
    global _global_executor
    executor, _global_executor = _global_executor, None
    if executor is not None:
        executor._is_shutdown = True  # noqa: SLF001 - its waitset dies with the participant


def create_node(node_name: str, **kwargs: Any) -> 'Node':
    from rclpy.node import Node
    return Node(node_name, **kwargs)


def spin(node: 'Node', executor: Optional['Executor'] = None) -> None:
    """Execute work until the context shuts down (or the executor is shut down)."""
    executor = get_global_executor() if executor is None else executor
    try:
        executor.add_node(node)
        while executor.context.ok():
            executor.spin_once()
    finally:
        executor.remove_node(node)


def spin_once(node: 'Node', *, executor: Optional['Executor'] = None,
              timeout_sec: Optional[float] = None) -> None:
    """Execute one item of work, waiting until `timeout_sec` (None: forever) for one."""
    executor = get_global_executor() if executor is None else executor
    try:
        executor.add_node(node)
        executor.spin_once(timeout_sec=timeout_sec)
    finally:
        executor.remove_node(node)


def spin_until_future_complete(node: 'Node', future: Any, executor: Optional['Executor'] = None,
                               timeout_sec: Optional[float] = None) -> None:
    executor = get_global_executor() if executor is None else executor
    try:
        executor.add_node(node)
        executor.spin_until_future_complete(future, timeout_sec)
    finally:
        executor.remove_node(node)
