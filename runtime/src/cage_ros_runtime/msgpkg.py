"""Lazy `<pkg>.msg` / `<pkg>.srv` / `<pkg>.action` modules: `from sensor_msgs.msg import LaserScan` builds
the class on first access.

Why lazy module attributes (PEP 562) instead of generated source: the type store is the single source of
truth (rosbags' Jazzy definitions and the project's interface files), so nothing generated can go stale.
The thin package directories that call this live next to `rclpy/` in this distribution; being ordinary
packages on sys.path, a real ROS 2 install earlier on sys.path (its PYTHONPATH entries) always wins.

Services and actions get rosidl's Python surface: `Trigger.Request`, `Trigger.Response`, `Trigger.Event`;
`Navigate.Goal`, `.Result`, `.Feedback` and `Navigate.Impl.SendGoalService`, `.GetResultService`,
`.FeedbackMessage`, `.CancelGoalService`, `.GoalStatusMessage`.
"""

from __future__ import annotations

import functools
from typing import Any, Callable

from cage_ros_runtime.messages import message_class
from cage_ros_runtime.typestore import typestore

_SUFFIXES = ('_Request', '_Response', '_Event', '_Goal', '_Result', '_Feedback', '_FeedbackMessage',
             '_SendGoal', '_GetResult')


def names(package: str, kind: str = 'msg') -> list[str]:
    """Interface names of `package` of one kind (`msg`, `srv`, `action`) in the type store."""
    prefix = f'{package}/{kind}/'
    found = {n[len(prefix):] for n in typestore().fielddefs if n.startswith(prefix)}
    if kind == 'msg':
        return sorted(found)
    # services/actions are registered with their description type `pkg/kind/Name` (fields *_message)
    return sorted(n for n in found if _is_description(f'{prefix}{n}', kind))


def _is_description(ros_type: str, kind: str) -> bool:
    fields = [f for f, _ in typestore().fielddefs[ros_type][1]]
    if kind == 'srv':
        return fields == ['request_message', 'response_message', 'event_message']
    return fields[:3] == ['goal', 'result', 'feedback'] and 'feedback_message' in fields


class ServiceType:
    """Base of service classes (`Trigger.Request`, `Trigger.Response`, `Trigger.Event`)."""

    _type = ''
    Request: Any = None
    Response: Any = None
    Event: Any = None


class ActionType:
    """Base of action classes (`Navigate.Goal`, ... and `Navigate.Impl.*`)."""

    _type = ''
    Goal: Any = None
    Result: Any = None
    Feedback: Any = None
    Impl: Any = None


@functools.lru_cache(maxsize=None)
def service_class(ros_type: str) -> type[ServiceType]:
    """The class of service `pkg/srv/Name` (or an action's `pkg/action/Name_SendGoal`)."""
    if ros_type not in typestore().fielddefs:
        raise ImportError(f'unknown service type {ros_type!r}')
    pkg, kind, name = ros_type.split('/')
    return type(name, (ServiceType,), {
        '__module__': f'{pkg}.{kind}', '__qualname__': name, '_type': ros_type,
        'Request': message_class(f'{ros_type}_Request'),
        'Response': message_class(f'{ros_type}_Response'),
        'Event': message_class(f'{ros_type}_Event')})


@functools.lru_cache(maxsize=None)
def action_class(ros_type: str) -> type[ActionType]:
    """The class of action `pkg/action/Name`."""
    if ros_type not in typestore().fielddefs:
        raise ImportError(f'unknown action type {ros_type!r}')
    pkg, kind, name = ros_type.split('/')
    impl = type('Impl', (), {
        'SendGoalService': service_class(f'{ros_type}_SendGoal'),
        'GetResultService': service_class(f'{ros_type}_GetResult'),
        'FeedbackMessage': message_class(f'{ros_type}_FeedbackMessage'),
        'CancelGoalService': service_class('action_msgs/srv/CancelGoal'),
        'GoalStatusMessage': message_class('action_msgs/msg/GoalStatusArray')})
    return type(name, (ActionType,), {
        '__module__': f'{pkg}.{kind}', '__qualname__': name, '_type': ros_type,
        'Goal': message_class(f'{ros_type}_Goal'), 'Result': message_class(f'{ros_type}_Result'),
        'Feedback': message_class(f'{ros_type}_Feedback'), 'Impl': impl})


def module_hooks(package: str, kind: str = 'msg') -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """`(__getattr__, __dir__)` for the `msg`, `srv` or `action` module of `package`."""

    def __getattr__(attr: str) -> Any:
        if attr.startswith('__'):
            raise AttributeError(attr)
        ros_type = f'{package}/{kind}/{attr}'
        if ros_type not in typestore().fielddefs:
            raise AttributeError(f"module '{package}.{kind}' has no {kind} {attr!r}")
        if kind == 'msg':
            return message_class(ros_type)
        if kind == 'srv':
            return service_class(ros_type)
        return action_class(ros_type)

    def __dir__() -> list[str]:
        return names(package, kind)

    return __getattr__, __dir__


def interface_class(name: str) -> Any:
    """`pkg/msg/Name`, `pkg/srv/Name`, `pkg/action/Name` (or `pkg/Name` for a message) -> its class."""
    parts = name.split('/')
    if len(parts) == 2:
        parts = [parts[0], 'msg', parts[1]]
    if len(parts) != 3 or parts[1] not in ('msg', 'srv', 'action'):
        raise ValueError(f'not an interface name: {name!r} (expected pkg/msg|srv|action/Name)')
    ros_type = '/'.join(parts)
    if ros_type not in typestore().fielddefs:
        raise ValueError(f'unknown interface {ros_type!r}')
    return {'msg': message_class, 'srv': service_class, 'action': action_class}[parts[1]](ros_type)


def type_of_service(srv_type: Any) -> str:
    """`pkg/srv/Name` of a service class (what create_service/create_client accept)."""
    name = getattr(srv_type, '_type', None)
    if not isinstance(name, str) or getattr(srv_type, 'Request', None) is None:
        raise TypeError(f'{srv_type!r} is not a service class of this runtime')
    return name
