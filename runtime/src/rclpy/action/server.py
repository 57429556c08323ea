"""rclpy.action.server: ActionServer and ServerGoalHandle (rclpy's API and rcl_action's behaviour).

Goal life cycle: ACCEPTED -> EXECUTING -> (CANCELING ->) SUCCEEDED | ABORTED | CANCELED.  Every change is
published on `<action>/_action/status` (latched, all goals known).  Results are kept for `result_timeout`
seconds after the goal ends; `get_result` requests for a goal still running are answered when it ends.
Callbacks (goal, cancel, execute) may be plain functions or coroutines; they run as executor tasks.
"""

from __future__ import annotations

import inspect
import threading
import time
from enum import Enum
from typing import Any, Callable, Dict, List, Optional

from action_msgs.msg import GoalInfo, GoalStatus, GoalStatusArray
from action_msgs.srv import CancelGoal

from rclpy.action.common import (FEEDBACK_QOS, SERVICE_QOS, STATUS_QOS, encode_status_array,
                                 entity_names, goal_key, zero_time)
from rclpy.service import Service


class GoalResponse(Enum):
    REJECT = 1
    ACCEPT = 2


class CancelResponse(Enum):
    REJECT = 1
    ACCEPT = 2


def default_goal_callback(goal_request: Any) -> GoalResponse:
    return GoalResponse.ACCEPT


def default_handle_accepted_callback(goal_handle: 'ServerGoalHandle') -> None:
    goal_handle.execute()


def default_cancel_callback(cancel_request: Any) -> CancelResponse:
    return CancelResponse.REJECT


_TERMINAL = {GoalStatus.STATUS_SUCCEEDED, GoalStatus.STATUS_ABORTED, GoalStatus.STATUS_CANCELED}


async def _await_or_execute(callback: Callable[..., Any], *args: Any) -> Any:
    out = callback(*args)
    if inspect.isawaitable(out):
        out = await out
    return out


class ServerGoalHandle:
    """One accepted goal on the server side."""

    def __init__(self, server: 'ActionServer', goal_info: Any, goal_request: Any) -> None:
        self._server = server
        self._goal_info = goal_info
        self._goal_request = goal_request
        self._status = GoalStatus.STATUS_ACCEPTED
        self._key = goal_key(goal_info.goal_id)
        self._lock = threading.Lock()
        self._terminal_time: Optional[float] = None

    @property
    def request(self) -> Any:
        return self._goal_request

    @property
    def goal_id(self) -> Any:
        return self._goal_info.goal_id

    @property
    def status(self) -> int:
        return self._status

    @property
    def is_active(self) -> bool:
        return self._status not in _TERMINAL

    @property
    def is_executing(self) -> bool:
        return self._status == GoalStatus.STATUS_EXECUTING

    @property
    def is_cancel_requested(self) -> bool:
        return self._status == GoalStatus.STATUS_CANCELING

    def _transition(self, new: int, allowed: set) -> None:
        with self._lock:
            if self._status not in allowed:
                raise RuntimeError(f'goal cannot go from status {self._status} to {new}')
            self._status = new
            if new in _TERMINAL:
                self._terminal_time = time.monotonic()
        self._server._publish_status()  # noqa: SLF001

    def execute(self, execute_callback: Optional[Callable[..., Any]] = None) -> None:
        """Start executing (ACCEPTED -> EXECUTING) and schedule the execute callback."""
        if self._status == GoalStatus.STATUS_ACCEPTED:
            self._transition(GoalStatus.STATUS_EXECUTING, {GoalStatus.STATUS_ACCEPTED})
        self._server._notify_execute(self, execute_callback)  # noqa: SLF001

    def publish_feedback(self, feedback: Any) -> None:
        msg = self._server._action_type.Impl.FeedbackMessage()  # noqa: SLF001
        msg.goal_id = self.goal_id
        msg.feedback = feedback
        self._server._feedback_pub.publish(msg)  # noqa: SLF001

    def succeed(self) -> None:
        self._transition(GoalStatus.STATUS_SUCCEEDED,
                         {GoalStatus.STATUS_EXECUTING, GoalStatus.STATUS_CANCELING})

    def abort(self) -> None:
        self._transition(GoalStatus.STATUS_ABORTED,
                         {GoalStatus.STATUS_ACCEPTED, GoalStatus.STATUS_EXECUTING,
                          GoalStatus.STATUS_CANCELING})

    def canceled(self) -> None:
        self._transition(GoalStatus.STATUS_CANCELED, {GoalStatus.STATUS_CANCELING})

    def _cancel(self) -> None:
        self._transition(GoalStatus.STATUS_CANCELING,
                         {GoalStatus.STATUS_ACCEPTED, GoalStatus.STATUS_EXECUTING})

    def destroy(self) -> None:
        pass


class ActionServer:
    """rclpy.action.ActionServer(node, action_type, action_name, execute_callback, ...)."""

    def __init__(self, node: Any, action_type: Any, action_name: str,
                 execute_callback: Callable[[ServerGoalHandle], Any], *,
                 callback_group: Any = None,
                 goal_callback: Callable[[Any], Any] = default_goal_callback,
                 handle_accepted_callback: Callable[[ServerGoalHandle], Any] = default_handle_accepted_callback,
                 cancel_callback: Callable[[Any], Any] = default_cancel_callback,
                 goal_service_qos_profile: Any = SERVICE_QOS,
                 result_service_qos_profile: Any = SERVICE_QOS,
                 cancel_service_qos_profile: Any = SERVICE_QOS,
                 feedback_pub_qos_profile: Any = FEEDBACK_QOS,
                 status_pub_qos_profile: Any = STATUS_QOS,
                 result_timeout: int = 900) -> None:
        self._node = node
        self._action_type = action_type
        self._action_name = node.resolve_topic_name(action_name)
        self._execute_callback = execute_callback
        self._goal_callback = goal_callback
        self._handle_accepted_callback = handle_accepted_callback
        self._cancel_callback = cancel_callback
        self._result_timeout = float(result_timeout)
        self._goals: Dict[bytes, ServerGoalHandle] = {}
        self._results: Dict[bytes, Any] = {}
        self._result_waiters: Dict[bytes, List[Any]] = {}
        self._lock = threading.RLock()
        names = entity_names(self._action_name)
        impl = action_type.Impl
        self._goal_srv = Service(node, impl.SendGoalService, names['send_goal'], None,
                                 goal_service_qos_profile)
        self._goal_srv._raw_handler = self._on_goal_request  # type: ignore[attr-defined]
        self._cancel_srv = Service(node, CancelGoal, names['cancel_goal'], None, cancel_service_qos_profile)
        self._cancel_srv._raw_handler = self._on_cancel_request  # type: ignore[attr-defined]
        self._result_srv = Service(node, impl.GetResultService, names['get_result'], None,
                                   result_service_qos_profile)
        self._result_srv._raw_handler = self._on_result_request  # type: ignore[attr-defined]
        self._feedback_pub = node.create_publisher(impl.FeedbackMessage, names['feedback'],
                                                   feedback_pub_qos_profile)
        self._status_pub = node.create_publisher(GoalStatusArray, names['status'], status_pub_qos_profile)
        self._destroyed = False
        node.add_waitable(self)
        node.context._graph_changed()  # noqa: SLF001

    # ------------------------------------------------------------------ executor interface
    def _entities(self) -> dict:
        return {'_services': [self._goal_srv, self._cancel_srv, self._result_srv]}

    def _spawn(self, fn: Callable[..., Any], *args: Any) -> Any:
        executor = self._node.executor
        if executor is None:
            raise RuntimeError('the action server node is not added to an executor')
        return executor.create_task(fn, *args)

    # ------------------------------------------------------------------ goal requests
    def _on_goal_request(self, request: Any, header: Any) -> None:
        self._spawn(self._handle_goal, request, header)

    async def _handle_goal(self, request: Any, header: Any) -> None:
        key = goal_key(request.goal_id)
        response = self._action_type.Impl.SendGoalService.Response()
        with self._lock:
            duplicate = key in self._goals
        accepted = False
        if duplicate:
            self._node.get_logger().error(f'{self._action_name}: goal id already in use; rejected')
        else:
            try:
                verdict = await _await_or_execute(self._goal_callback, request.goal)
                accepted = verdict == GoalResponse.ACCEPT
            except Exception as exc:  # noqa: BLE001 - a raising callback rejects the goal
                self._node.get_logger().error(f'{self._action_name}: goal callback raised {exc!r}')
        response.accepted = accepted
        stamp = self._node.get_clock().now().to_msg()
        response.stamp = stamp
        handle = None
        if accepted:
            handle = ServerGoalHandle(self, GoalInfo(goal_id=request.goal_id, stamp=stamp), request.goal)
            with self._lock:
                self._goals[key] = handle
        self._goal_srv.send_response(response, header)
        if handle is not None:
            self._publish_status()
            await _await_or_execute(self._handle_accepted_callback, handle)

    def _notify_execute(self, handle: ServerGoalHandle, execute_callback: Optional[Callable]) -> None:
        self._spawn(self._execute_goal, handle, execute_callback or self._execute_callback)

    async def _execute_goal(self, handle: ServerGoalHandle, execute_callback: Callable) -> None:
        try:
            result = await _await_or_execute(execute_callback, handle)
        except Exception as exc:  # noqa: BLE001 - as rclpy: log, abort with an empty result
            self._node.get_logger().error(f'{self._action_name}: execute callback raised {exc!r}')
            result = None
            if handle.is_active:
                handle._status = GoalStatus.STATUS_ABORTED  # noqa: SLF001
                handle._terminal_time = time.monotonic()  # noqa: SLF001
        if handle.is_active:
            self._node.get_logger().warning(
                f'{self._action_name}: goal state not set, assuming aborted')
            handle._status = GoalStatus.STATUS_ABORTED  # noqa: SLF001
            handle._terminal_time = time.monotonic()  # noqa: SLF001
        if result is None or not isinstance(result, self._action_type.Result):
            if result is not None:
                self._node.get_logger().error(
                    f'{self._action_name}: execute callback returned {type(result).__name__}, '
                    f'not {self._action_type.Result.__name__}')
            result = self._action_type.Result()
        response = self._action_type.Impl.GetResultService.Response(status=handle.status, result=result)
        key = goal_key(handle.goal_id)
        with self._lock:
            self._results[key] = response
            waiters = self._result_waiters.pop(key, [])
        self._publish_status()
        for header in waiters:
            self._result_srv.send_response(response, header)

    # ------------------------------------------------------------------ results
    def _on_result_request(self, request: Any, header: Any) -> None:
        key = goal_key(request.goal_id)
        with self._lock:
            self._expire()
            response = self._results.get(key)
            known = key in self._goals
            if response is None and known:
                self._result_waiters.setdefault(key, []).append(header)
                return
        if response is None:  # unknown goal: STATUS_UNKNOWN and an empty result, as rcl_action
            response = self._action_type.Impl.GetResultService.Response(status=GoalStatus.STATUS_UNKNOWN)
        self._result_srv.send_response(response, header)

    def _expire(self) -> None:
        now = time.monotonic()
        for key, handle in list(self._goals.items()):
            t = handle._terminal_time  # noqa: SLF001
            if t is not None and key in self._results and now - t > self._result_timeout:
                del self._goals[key]
                self._results.pop(key, None)

    # ------------------------------------------------------------------ cancel
    def _on_cancel_request(self, request: Any, header: Any) -> None:
        self._spawn(self._handle_cancel, request, header)

    async def _handle_cancel(self, request: Any, header: Any) -> None:
        info = request.goal_info
        key = goal_key(info.goal_id)
        everything = not any(key) and zero_time(info.stamp)
        response = CancelGoal.Response()
        with self._lock:
            candidates = []
            for k, handle in self._goals.items():
                stamp = handle._goal_info.stamp  # noqa: SLF001
                before = not zero_time(info.stamp) and \
                    (stamp.sec, stamp.nanosec) <= (info.stamp.sec, info.stamp.nanosec)
                if everything or k == key or before:
                    candidates.append(handle)
        if not candidates:
            response.return_code = CancelGoal.Response.ERROR_UNKNOWN_GOAL_ID if any(key) \
                else CancelGoal.Response.ERROR_NONE
        for handle in candidates:
            if not handle.is_active:
                continue
            try:
                verdict = await _await_or_execute(self._cancel_callback, handle)
            except Exception as exc:  # noqa: BLE001
                self._node.get_logger().error(f'{self._action_name}: cancel callback raised {exc!r}')
                verdict = CancelResponse.REJECT
            if verdict == CancelResponse.ACCEPT and handle.is_active:
                if not handle.is_cancel_requested:
                    handle._cancel()  # noqa: SLF001
                response.goals_canceling.append(handle._goal_info)  # noqa: SLF001
        if candidates and not response.goals_canceling:
            response.return_code = CancelGoal.Response.ERROR_GOAL_TERMINATED \
                if all(not h.is_active for h in candidates) else CancelGoal.Response.ERROR_REJECTED
        self._cancel_srv.send_response(response, header)

    # ------------------------------------------------------------------ status
    def _publish_status(self) -> None:
        if self._destroyed:
            return
        with self._lock:
            self._expire()
            entries = [(key, h._goal_info.stamp.sec, h._goal_info.stamp.nanosec, h.status)  # noqa: SLF001
                       for key, h in self._goals.items()]
        self._status_pub.publish(encode_status_array(entries))

    def destroy(self) -> None:
        if self._destroyed:
            return
        self._destroyed = True
        self._node.remove_waitable(self)
        for srv in (self._goal_srv, self._cancel_srv, self._result_srv):
            srv._close()  # noqa: SLF001
        self._node.destroy_publisher(self._feedback_pub)
        self._node.destroy_publisher(self._status_pub)
        self._node.context._graph_changed()  # noqa: SLF001
