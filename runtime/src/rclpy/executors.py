"""rclpy.executors: a single-threaded executor that blocks on a DDS WaitSet.

Why a WaitSet: latency.  The executor sleeps inside Cyclone (read conditions of every subscription plus the
context's guard condition) and wakes the moment a sample arrives, a timer is due, or the context shuts down;
nothing polls with sleeps.  Waits are sliced to at most 100 ms only so that Python gets a chance to run
signal handlers (they run between bytecodes, never inside a C call).  All callbacks run in the spinning
thread, one per `spin_once`, timers before subscriptions, in arrival order.

Service callbacks, action callbacks and `create_task` work run as :class:`rclpy.task.Task`s, so they may
be coroutines that `await` futures (a reply, a goal's result); a suspended task is re-queued by the
future it waits on.  Waitables (action servers and clients) expose `_entities()` (their services,
clients, subscriptions) and are served like the node's own.
"""

from __future__ import annotations

import functools
import time
from collections import deque
from typing import Any, Callable, Deque, List, Optional

from cyclonedds.core import WaitSet

from cage_ros_runtime.dds import delete_entity
from rclpy.context import Context
from rclpy.task import Task
from rclpy.utilities import get_default_context

#: Longest uninterrupted wait inside Cyclone, so pending Python signal handlers run promptly.
_WAIT_SLICE_NS = 100_000_000


class ExternalShutdownException(Exception):
    """Context has been shut down (by rclpy.shutdown() elsewhere or by a signal)."""


class ShutdownException(Exception):
    """Signal that the executor was shut down."""


class TimeoutException(Exception):
    """Signal that a timeout occurred."""


class ConditionReachedException(Exception):
    """A wait condition was met."""


class Executor:
    """Runs the callbacks of the nodes added to it (rclpy.executors.Executor)."""

    def __init__(self, *, context: Optional[Context] = None) -> None:
        self._context = get_default_context() if context is None else context
        self._nodes: List[Any] = []
        self._ready: Deque[Callable[[], None]] = deque()
        self._waitset: Optional[WaitSet] = None
        self._waitset_key: Any = None
        self._is_shutdown = False

    @property
    def context(self) -> Context:
        return self._context

    # ------------------------------------------------------------------ nodes
    def add_node(self, node: Any) -> bool:
        if node in self._nodes:
            return False
        self._nodes.append(node)
        node.executor = self
        self.wake()
        return True

    def remove_node(self, node: Any) -> None:
        if node in self._nodes:
            self._nodes.remove(node)
            node.executor = None
            self.wake()

    def get_nodes(self) -> List[Any]:
        return list(self._nodes)

    def wake(self) -> None:
        """Make a blocked wait return (the context's guard condition)."""
        self._context._wake()  # noqa: SLF001

    def create_task(self, callback: Callable[..., Any], *args: Any, **kwargs: Any) -> Task:
        """Run `callback(*args)` (a function or coroutine function) in this executor; returns its Task."""
        task = Task(callback, args, kwargs, executor=self)
        self._requeue(task)
        return task

    def _requeue(self, task: Task) -> None:
        """Queue a task (new, or resumed because what it awaited is done); thread-safe."""
        self._ready.append(task)
        self.wake()

    def shutdown(self, timeout_sec: Optional[float] = None) -> bool:
        self._is_shutdown = True
        self.wake()
        for node in list(self._nodes):
            self.remove_node(node)
        if self._waitset is not None:
            delete_entity(self._waitset)
            self._waitset = None
        return True

    # ------------------------------------------------------------------ spinning
    def spin(self) -> None:
        while self._context.ok() and not self._is_shutdown:
            self.spin_once()

    def spin_once(self, timeout_sec: Optional[float] = None) -> None:
        """Run at most one ready callback, waiting up to `timeout_sec` (None: forever) for one.

        Raises ExternalShutdownException when the context is shut down while (or before) waiting.
        """
        try:
            callback = self._next_callback(timeout_sec)
        except (ShutdownException, TimeoutException):
            return
        if callback is not None:
            callback()

    def spin_until_future_complete(self, future: Any, timeout_sec: Optional[float] = None) -> None:
        deadline = None if timeout_sec is None or timeout_sec < 0 else time.monotonic() + timeout_sec
        while self._context.ok() and not future.done() and not self._is_shutdown:
            remaining = None if deadline is None else deadline - time.monotonic()
            if remaining is not None and remaining <= 0:
                return
            self.spin_once(remaining)

    def spin_once_until_future_complete(self, future: Any, timeout_sec: Optional[float] = None) -> None:
        self.spin_once(timeout_sec)

    # ------------------------------------------------------------------ internals
    def _ensure_waitset(self) -> Optional[WaitSet]:
        domain = self._context._domain  # noqa: SLF001
        if domain is None:
            return None
        key = (id(domain), tuple((id(n), n._generation) for n in self._nodes))  # noqa: SLF001
        if key != self._waitset_key or self._waitset is None:
            if self._waitset is not None:
                delete_entity(self._waitset)
            ws = WaitSet(domain.participant)
            ws.attach(domain.guard)
            for node in self._nodes:
                for entity in _readable_entities(node):
                    if entity._reader is not None:  # noqa: SLF001
                        ws.attach(entity._reader.condition)  # noqa: SLF001
            self._waitset, self._waitset_key = ws, key
        return self._waitset

    def _collect(self) -> int:
        """Queue due timers, then every sample available now; returns the next timer deadline or -1."""
        now = time.monotonic_ns()
        next_deadline = -1
        for node in self._nodes:
            for timer in list(node._timers):  # noqa: SLF001
                sim_due = timer._sim_due()  # noqa: SLF001
                if sim_due is not None:  # a sim-time timer: woken by /clock, not by the steady clock
                    if sim_due:
                        self._ready.append(timer._fire)  # noqa: SLF001
                    continue
                deadline = timer._next_deadline()  # noqa: SLF001
                if deadline is None:
                    continue
                if deadline <= now:
                    self._ready.append(timer._fire)  # noqa: SLF001
                elif next_deadline < 0 or deadline < next_deadline:
                    next_deadline = deadline
        self._pending_replies = False
        for node in self._nodes:
            for sub in _all_subscriptions(node):
                for data in sub._take():  # noqa: SLF001
                    self._ready.append(functools.partial(sub._dispatch, data))  # noqa: SLF001
            for srv in _all_services(node):
                for request, header in srv._take():  # noqa: SLF001
                    self._ready.append(functools.partial(self._run_service, srv, request, header))
                if srv._flush_pending():  # noqa: SLF001
                    self._pending_replies = True
            for client in _all_clients(node):
                for future, response in client._take():  # noqa: SLF001
                    self._ready.append(functools.partial(_complete, future, response))
        return next_deadline

    def _run_service(self, srv: Any, request: Any, header: Any) -> None:
        """Run a service callback as a task; its returned response is sent when the task is done."""
        raw = getattr(srv, '_raw_handler', None)
        if raw is not None:  # action servers answer on their own schedule
            raw(request, header)
            return
        task = Task(srv.callback, (request, srv.srv_type.Response()), executor=self)

        def reply(t: Task) -> None:
            exc = t.exception()
            if exc is not None:
                srv._node.get_logger().error(  # noqa: SLF001
                    f'service {srv.srv_name}: callback raised {type(exc).__name__}: {exc}')
                return
            try:
                srv.send_response(t.result(), header)
            except Exception as err:  # noqa: BLE001 - a bad response must not stop the executor
                srv._node.get_logger().error(f'service {srv.srv_name}: {err}')  # noqa: SLF001

        task.add_done_callback(reply)
        task()

    def _next_callback(self, timeout_sec: Optional[float]) -> Optional[Callable[[], None]]:
        deadline = None if timeout_sec is None or timeout_sec < 0 else \
            time.monotonic_ns() + int(timeout_sec * 1e9)
        while True:
            if self._ready:
                return self._ready.popleft()
            if not self._context.ok():
                raise ExternalShutdownException()
            if self._is_shutdown:
                raise ShutdownException()
            next_timer = self._collect()
            if self._ready:
                return self._ready.popleft()
            now = time.monotonic_ns()
            wait_ns = _WAIT_SLICE_NS if not getattr(self, '_pending_replies', False) else 10_000_000
            if next_timer >= 0:
                wait_ns = min(wait_ns, max(0, next_timer - now))
            if deadline is not None:
                if now >= deadline:
                    raise TimeoutException()
                wait_ns = min(wait_ns, deadline - now)
            ws = self._ensure_waitset()
            if ws is None:
                time.sleep(wait_ns / 1e9)  # no participant yet (no node): nothing can arrive
                continue
            if wait_ns > 0:
                ws.wait(wait_ns)
            guard = self._context._domain.guard if self._context._domain else None  # noqa: SLF001
            if guard is not None and self._context.ok():
                guard.set(False)


def _complete(future: Any, response: Any) -> None:
    if not future.done():
        future.set_result(response)


def _waitable_entities(node: Any, attr: str) -> list:
    out = list(getattr(node, attr))
    for waitable in node._waitables:  # noqa: SLF001
        out.extend(waitable._entities().get(attr, ()))  # noqa: SLF001
    return out


def _all_subscriptions(node: Any) -> list:
    return _waitable_entities(node, '_subscriptions')


def _all_services(node: Any) -> list:
    return _waitable_entities(node, '_services')


def _all_clients(node: Any) -> list:
    return _waitable_entities(node, '_clients')


def _readable_entities(node: Any) -> list:
    return _all_subscriptions(node) + _all_services(node) + _all_clients(node)


class SingleThreadedExecutor(Executor):
    """Runs callbacks in the thread that spins."""


class MultiThreadedExecutor(Executor):
    """Accepted for compatibility; runs callbacks one at a time in the spinning thread."""

    def __init__(self, num_threads: Optional[int] = None, *, context: Optional[Context] = None) -> None:
        super().__init__(context=context)
