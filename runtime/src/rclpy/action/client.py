"""rclpy.action.client: ActionClient and ClientGoalHandle (rclpy's API over rcl_action's entities)."""

from __future__ import annotations

import threading
import time
from typing import Any, Callable, Dict, Optional

from action_msgs.msg import GoalInfo, GoalStatus, GoalStatusArray
from action_msgs.srv import CancelGoal

from rclpy.action.common import (FEEDBACK_QOS, SERVICE_QOS, STATUS_QOS, decode_status_array,
                                 entity_names, goal_key, new_goal_id)
from rclpy.client import Client
from rclpy.task import Future


class ClientGoalHandle:
    """A goal sent by an ActionClient: accepted or not, its id and stamp, the last status seen."""

    def __init__(self, action_client: 'ActionClient', goal_id: Any, goal_response: Any) -> None:
        self._action_client = action_client
        self._goal_id = goal_id
        self._goal_response = goal_response
        self._status = GoalStatus.STATUS_UNKNOWN

    def __eq__(self, other: object) -> bool:
        return isinstance(other, ClientGoalHandle) and goal_key(self._goal_id) == goal_key(other._goal_id)

    def __hash__(self) -> int:
        return hash(goal_key(self._goal_id))

    @property
    def goal_id(self) -> Any:
        return self._goal_id

    @property
    def stamp(self) -> Any:
        return self._goal_response.stamp

    @property
    def accepted(self) -> bool:
        return bool(self._goal_response.accepted)

    @property
    def status(self) -> int:
        return self._status

    def cancel_goal_async(self) -> Future:
        return self._action_client._cancel_goal_async(self)  # noqa: SLF001

    def get_result_async(self) -> Future:
        return self._action_client._get_result_async(self)  # noqa: SLF001

    def cancel_goal(self) -> Any:
        return self._action_client._wait(self.cancel_goal_async())  # noqa: SLF001

    def get_result(self) -> Any:
        return self._action_client._wait(self.get_result_async())  # noqa: SLF001

    def __repr__(self) -> str:
        return f'ClientGoalHandle <id={list(goal_key(self._goal_id))}, accepted={self.accepted}, ' \
               f'status={self.status}>'


class ActionClient:
    """rclpy.action.ActionClient(node, action_type, action_name, ...)."""

    def __init__(self, node: Any, action_type: Any, action_name: str, *, callback_group: Any = None,
                 goal_service_qos_profile: Any = SERVICE_QOS,
                 result_service_qos_profile: Any = SERVICE_QOS,
                 cancel_service_qos_profile: Any = SERVICE_QOS,
                 feedback_sub_qos_profile: Any = FEEDBACK_QOS,
                 status_sub_qos_profile: Any = STATUS_QOS) -> None:
        self._node = node
        self._action_type = action_type
        self._action_name = node.resolve_topic_name(action_name)
        names = entity_names(self._action_name)
        impl = action_type.Impl
        self._goal_client = Client(node, impl.SendGoalService, names['send_goal'], goal_service_qos_profile)
        self._cancel_client = Client(node, CancelGoal, names['cancel_goal'], cancel_service_qos_profile)
        self._result_client = Client(node, impl.GetResultService, names['get_result'],
                                     result_service_qos_profile)
        self._feedback_sub = node.create_subscription(impl.FeedbackMessage, names['feedback'],
                                                      self._on_feedback, feedback_sub_qos_profile)
        self._status_sub = node.create_subscription(GoalStatusArray, names['status'], self._on_status,
                                                    status_sub_qos_profile, raw=True)
        self._feedback_callbacks: Dict[bytes, Callable[[Any], None]] = {}
        self._handles: Dict[bytes, ClientGoalHandle] = {}
        self._last_status: Dict[bytes, int] = {}  # a status can arrive before the goal response
        self._lock = threading.Lock()
        self._destroyed = False
        node.add_waitable(self)
        node.context._graph_changed()  # noqa: SLF001

    def _entities(self) -> dict:
        return {'_clients': [self._goal_client, self._cancel_client, self._result_client]}

    # ------------------------------------------------------------------ topics
    def _on_feedback(self, msg: Any) -> None:
        with self._lock:
            callback = self._feedback_callbacks.get(goal_key(msg.goal_id))
        if callback is not None:
            callback(msg)

    def _on_status(self, data: bytes) -> None:
        """Status array, decoded by the fast codec (it grows with every goal the server keeps)."""
        try:
            entries = decode_status_array(data)
        except Exception:  # noqa: BLE001 - a malformed status message is ignored
            return
        with self._lock:
            self._last_status = {key: status for key, _s, _n, status in entries}
            for key, status in self._last_status.items():
                handle = self._handles.get(key)
                if handle is not None:
                    handle._status = status  # noqa: SLF001

    # ------------------------------------------------------------------ goals
    def send_goal_async(self, goal: Any, feedback_callback: Optional[Callable[[Any], None]] = None,
                        goal_uuid: Any = None) -> Future:
        """Send a goal; the Future completes with a ClientGoalHandle (accepted or not)."""
        if not isinstance(goal, self._action_type.Goal):
            raise TypeError(f'Expected {self._action_type.Goal}, got {type(goal)}')
        goal_id = goal_uuid if goal_uuid is not None else new_goal_id()
        request = self._action_type.Impl.SendGoalService.Request(goal_id=goal_id, goal=goal)
        key = goal_key(goal_id)
        if feedback_callback is not None:
            with self._lock:
                self._feedback_callbacks[key] = feedback_callback
        outer = Future()
        inner = self._goal_client.call_async(request)

        def done(f: Future) -> None:
            exc = f.exception()
            if exc is not None:
                outer.set_exception(exc)
                return
            handle = ClientGoalHandle(self, goal_id, f.result())
            with self._lock:
                if handle.accepted:
                    self._handles[key] = handle
                    handle._status = self._last_status.get(key, GoalStatus.STATUS_ACCEPTED)  # noqa: SLF001
                else:
                    self._feedback_callbacks.pop(key, None)
            outer.set_result(handle)

        inner.add_done_callback(done)
        return outer

    def send_goal(self, goal: Any, feedback_callback: Optional[Callable[[Any], None]] = None,
                  goal_uuid: Any = None) -> Any:
        """Blocking: the goal's result response (needs an executor spinning in another thread)."""
        handle = self._wait(self.send_goal_async(goal, feedback_callback, goal_uuid))
        if handle is None or not handle.accepted:
            return None
        return self._wait(handle.get_result_async())

    def _get_result_async(self, handle: ClientGoalHandle) -> Future:
        request = self._action_type.Impl.GetResultService.Request(goal_id=handle.goal_id)
        future = self._result_client.call_async(request)
        key = goal_key(handle.goal_id)

        def done(f: Future) -> None:
            if f.exception() is None:
                handle._status = f.result().status  # noqa: SLF001
            with self._lock:
                self._feedback_callbacks.pop(key, None)
                self._handles.pop(key, None)

        future.add_done_callback(done)
        return future

    def _cancel_goal_async(self, handle: ClientGoalHandle) -> Future:
        request = CancelGoal.Request(goal_info=GoalInfo(goal_id=handle.goal_id))
        return self._cancel_client.call_async(request)

    def get_result_async(self, goal_handle: ClientGoalHandle) -> Future:
        return self._get_result_async(goal_handle)

    def cancel_goal_async(self, goal_handle: ClientGoalHandle) -> Future:
        return self._cancel_goal_async(goal_handle)

    @staticmethod
    def _wait(future: Future, timeout: Optional[float] = None) -> Any:
        if not future._wait(timeout):  # noqa: SLF001
            return None
        return future.result()

    # ------------------------------------------------------------------ server presence
    def server_is_ready(self) -> bool:
        return all(c.service_is_ready() for c in (self._goal_client, self._cancel_client,
                                                  self._result_client))

    def wait_for_server(self, timeout_sec: Optional[float] = None) -> bool:
        deadline = None if timeout_sec is None else time.monotonic() + timeout_sec
        while self._node.context.ok():
            if self.server_is_ready():
                return True
            if deadline is not None and time.monotonic() >= deadline:
                return False
            time.sleep(0.01)
        return False

    def destroy(self) -> None:
        if self._destroyed:
            return
        self._destroyed = True
        self._node.remove_waitable(self)
        for client in (self._goal_client, self._cancel_client, self._result_client):
            client._close()  # noqa: SLF001
        self._node.destroy_subscription(self._feedback_sub)
        self._node.destroy_subscription(self._status_sub)
        self._node.context._graph_changed()  # noqa: SLF001
