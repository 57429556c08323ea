"""rclpy.context: the lifetime of a ROS "session": init -> ok() -> shutdown, one DDS participant.

The participant is created lazily with the first node (rmw_cyclonedds does the same), in the domain given
to `init(domain_id=...)` or by `ROS_DOMAIN_ID` (default 0).
"""

from __future__ import annotations

import os
import threading
import weakref
from typing import TYPE_CHECKING, Callable, List, Optional

from cage_ros_runtime import arguments as _arguments

if TYPE_CHECKING:
    from cage_ros_runtime.dds import Domain
    from cage_ros_runtime.graph import GraphObserver, GraphPublisher


def _domain_id_from_env() -> int:
    text = os.environ.get('ROS_DOMAIN_ID', '').strip()
    if not text:
        return 0
    try:
        value = int(text)
    except ValueError:
        raise RuntimeError(f'ROS_DOMAIN_ID is not an integer: {text!r}') from None
    if not 0 <= value <= 232:
        raise RuntimeError(f'ROS_DOMAIN_ID out of range [0, 232]: {value}')
    return value


class Context:
    """Encapsulates the lifecycle of init and shutdown (rclpy.context.Context)."""

    def __init__(self) -> None:
        self._lock = threading.RLock()
        self._initialized = False
        self._shutdown = False
        self._domain_id: Optional[int] = None
        self._domain: Optional['Domain'] = None
        self._graph: Optional['GraphPublisher'] = None
        self._observer: Optional['GraphObserver'] = None
        self._graph_batch = 0
        self._callbacks: List[Callable[[], None]] = []
        self._args = _arguments.RosArguments()
        self._argv: List[str] = []
        self._nodes: 'weakref.WeakSet' = weakref.WeakSet()

    # ------------------------------------------------------------------ lifecycle
    def init(self, args: Optional[List[str]] = None, *, initialize_logging: bool = True,
             domain_id: Optional[int] = None) -> None:
        with self._lock:
            if self.ok():
                raise RuntimeError('Context.init() must only be called once')
            import sys
            argv = list(sys.argv if args is None else args)
            self._args = _arguments.parse(argv)
            self._argv = argv
            if domain_id is not None and not 0 <= int(domain_id) <= 232:
                raise RuntimeError(f'domain_id out of range [0, 232]: {domain_id}')
            self._domain_id = int(domain_id) if domain_id is not None else _domain_id_from_env()
            self._apply_log_levels()
            self._initialized = True
            self._shutdown = False

    def _apply_log_levels(self) -> None:
        from rclpy.impl import rcutils_logger
        from rclpy.logging import get_logging_severity_from_string
        for name, level in self._args.log_levels:
            severity = get_logging_severity_from_string(level)
            if name is None:
                rcutils_logger.set_default_level(severity)
            else:
                rcutils_logger.set_level(name, severity)

    @property
    def handle(self) -> 'Context':
        return self

    def ok(self) -> bool:
        with self._lock:
            return self._initialized and not self._shutdown

    def _call_on_shutdown_callbacks(self) -> None:
        callbacks, self._callbacks = self._callbacks, []
        for cb in callbacks:
            cb()

    def shutdown(self) -> None:
        """Shut down; RuntimeError if not initialized or already shut down (like rclpy)."""
        with self._lock:
            if not self.ok():
                raise RuntimeError('Context must be initialized before it can be shutdown'
                                   if not self._initialized else 'Context already shutdown')
            self._shutdown = True
        self._wake()
        self._call_on_shutdown_callbacks()
        self._release()

    def try_shutdown(self) -> None:
        """Shut down if not already shut down, then release the DDS participant."""
        with self._lock:
            was_ok = self.ok()
            self._shutdown = self._shutdown or self._initialized
        if was_ok:
            self._wake()
            self._call_on_shutdown_callbacks()
        self._release()

    def _signal_shutdown(self) -> None:
        """What a SIGINT/SIGTERM does to a context: mark it shut down and wake every wait."""
        with self._lock:
            if not self.ok():
                return
            self._shutdown = True
        self._wake()
        self._call_on_shutdown_callbacks()

    def _wake(self) -> None:
        domain = self._domain
        if domain is not None:
            domain.guard.set(True)

    def _release(self) -> None:
        """Destroy remaining nodes and delete the participant."""
        for node in list(self._nodes):
            try:
                node.destroy_node()
            except Exception:  # noqa: BLE001 - best effort at teardown
                pass
        with self._lock:
            domain, self._domain, self._graph, self._observer = self._domain, None, None, None
        if domain is not None:
            domain.close()

    def on_shutdown(self, callback: Callable[[], None]) -> None:
        if not callable(callback):
            raise TypeError('callback should be a callable, got {}'.format(type(callback)))
        with self._lock:
            if not self.ok():
                callback()
            else:
                self._callbacks.append(callback)

    def get_domain_id(self) -> int:
        if self._domain_id is None:
            raise RuntimeError('Context is not initialized')
        return self._domain_id

    # ------------------------------------------------------------------ runtime internals
    @property
    def ros_arguments(self) -> _arguments.RosArguments:
        return self._args

    def _get_domain(self) -> 'Domain':
        with self._lock:
            if not self.ok():
                from rclpy.exceptions import NotInitializedException
                raise NotInitializedException('the context is not initialized or already shut down')
            if self._domain is None:
                from cage_ros_runtime.dds import Domain
                from cage_ros_runtime.graph import GraphObserver, GraphPublisher
                self._domain = Domain(self.get_domain_id())
                self._graph = GraphPublisher(self._domain)
                from cage_ros_runtime.graph import GraphObserver
                self._observer = GraphObserver(self._domain.participant)
            return self._domain

    def _graph_observer(self) -> 'GraphObserver':
        """Discovery data of this context's participant (builtin topics and ros_discovery_info)."""
        self._get_domain()
        return self._observer

    def _graph_changed(self) -> None:
        """Republish ros_discovery_info after a node or endpoint was created or destroyed (once for a
        whole node construction: a node makes ~16 endpoints before user code runs)."""
        graph = self._graph
        if graph is not None and not self._graph_batch:
            graph.publish(list(self._nodes))

    def _track_node(self, node: object) -> None:
        self._nodes.add(node)

    def _untrack_node(self, node: object) -> None:
        self._nodes.discard(node)
