"""`ros2 service call` and `ros2 action send_goal` (ros2cli's output, no traceback on bad input)."""

from __future__ import annotations

import argparse
import textwrap
import time
from typing import Any

import yaml

from cage_ros_runtime.cli_common import Tool, fail

_STATUS = {0: 'UNKNOWN', 1: 'ACCEPTED', 2: 'EXECUTING', 3: 'CANCELING', 4: 'SUCCEEDED', 5: 'CANCELED',
           6: 'ABORTED'}


def _interface(name: str, kind: str) -> Any:
    from cage_ros_runtime.msgpkg import interface_class
    parts = name.split('/')
    if len(parts) == 2:
        parts = [parts[0], kind, parts[1]]
    if len(parts) != 3 or parts[1] != kind:
        raise ValueError(f'The passed {"service" if kind == "srv" else "action"} type is invalid: {name}')
    return interface_class('/'.join(parts))


def _fill(cls: Any, text: str) -> Any:
    from cage_ros_runtime.yaml_format import set_fields_from_yaml
    try:
        values = yaml.safe_load(text) if text else None
    except yaml.YAMLError as exc:
        raise ValueError(f'the values are not valid YAML: {str(exc).splitlines()[0]}') from None
    if values is not None and not isinstance(values, dict):
        raise ValueError(f'the values must be a YAML mapping of field names, got {text!r}')
    return set_fields_from_yaml(cls(), values)


def _yaml(msg: Any, indent: int = 4) -> str:
    from cage_ros_runtime.yaml_format import message_to_yaml
    return textwrap.indent(message_to_yaml(msg, None), ' ' * indent).rstrip('\n')


def cmd_service_call(args: argparse.Namespace) -> int:
    try:
        srv = _interface(args.service_type, 'srv')
        request = _fill(srv.Request, args.values)
    except (ValueError, TypeError, AttributeError, AssertionError) as exc:
        return fail(str(exc), 2)
    with Tool() as tool:
        client = tool.node.create_client(srv, args.service_name)
        executor = tool.executor()
        print('waiting for service to become available...', flush=True)
        if not client.wait_for_service(timeout_sec=args.timeout):
            return fail(f"Service '{args.service_name}' is not available after {args.timeout} s", 1)
        period = 1.0 / args.rate if args.rate else None
        while True:
            print(f'requester: making request: {request!r}\n', flush=True)
            future = client.call_async(request)
            if not tool.spin_until(executor, future.done, args.timeout):
                return fail(f'no response from {args.service_name} within {args.timeout} s', 1)
            print(f'response:\n{future.result()!r}\n', flush=True)
            if period is None:
                return 0
            time.sleep(period)


def cmd_action_send_goal(args: argparse.Namespace) -> int:
    from rclpy.action import ActionClient
    try:
        action = _interface(args.action_type, 'action')
        goal = _fill(action.Goal, args.goal)
    except (ValueError, TypeError, AttributeError, AssertionError) as exc:
        return fail(str(exc), 2)
    with Tool() as tool:
        client = ActionClient(tool.node, action, args.action_name)
        executor = tool.executor()
        print('Waiting for an action server to become available...', flush=True)
        if not client.wait_for_server(timeout_sec=args.timeout):
            return fail(f"Action server '{args.action_name}' is not available after {args.timeout} s", 1)
        print(f'Sending goal:\n{_yaml(goal, 5)}\n', flush=True)

        def on_feedback(msg: Any) -> None:
            print(f'Feedback:\n{_yaml(msg.feedback)}\n', flush=True)

        sent = client.send_goal_async(goal, feedback_callback=on_feedback if args.feedback else None)
        if not tool.spin_until(executor, sent.done, args.timeout):
            return fail(f'no answer from {args.action_name} within {args.timeout} s', 1)
        handle = sent.result()
        if not handle.accepted:
            print('Goal was rejected.', flush=True)
            return 1
        print(f'Goal accepted with ID: {bytes(bytearray(handle.goal_id.uuid)).hex()}\n', flush=True)
        result = handle.get_result_async()
        try:
            if not tool.spin_until(executor, result.done, None):
                raise KeyboardInterrupt
        except KeyboardInterrupt:
            cancel = handle.cancel_goal_async()
            tool.spin_until(executor, cancel.done, 5.0)
            print('Goal canceled.', flush=True)
            return 1
        response = result.result()
        print(f'Result:\n{_yaml(response.result)}\n', flush=True)
        status = _STATUS.get(response.status, str(response.status))
        print(f'Goal finished with status: {status}', flush=True)
        return 0 if response.status == 4 else 1


def add_service_call_parser(ssub: Any) -> None:
    sc = ssub.add_parser('call', help='Call a service')
    sc.add_argument('service_name')
    sc.add_argument('service_type')
    sc.add_argument('values', nargs='?', default='')
    sc.add_argument('-r', '--rate', type=float)
    sc.add_argument('--timeout', type=float, default=10.0,
                    help='give up waiting for the service / the response after this long (s)')
    sc.set_defaults(func=cmd_service_call)


def add_send_goal_parser(asub: Any) -> None:
    sg = asub.add_parser('send_goal', help='Send an action goal')
    sg.add_argument('action_name')
    sg.add_argument('action_type')
    sg.add_argument('goal')
    sg.add_argument('-f', '--feedback', action='store_true', help='Echo feedback messages for the goal')
    sg.add_argument('--timeout', type=float, default=10.0,
                    help='give up waiting for the server / the goal response after this long (s)')
    sg.set_defaults(func=cmd_action_send_goal)
