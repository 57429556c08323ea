"""Actions across real processes: send_goal -> accepted, feedback, result, cancel, rejection, status."""

from __future__ import annotations

from typing import Any, Callable

from runtime_testlib import spin_until


def test_action_goal_feedback_result_cancel_reject(spawn: Callable[..., Any], context: Any) -> None:
    from action_msgs.msg import GoalStatus
    from action_msgs.srv import CancelGoal
    from example_interfaces.action import Fibonacci
    from rclpy.action import ActionClient
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node

    server = spawn('fibonacci_server.py')
    assert server.read_until('READY', 60), server.output
    node = Node('fib_client', context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    client = ActionClient(node, Fibonacci, 'fibonacci')
    assert client.wait_for_server(timeout_sec=20)

    # a goal to its end, with feedback
    feedback: list = []
    sent = client.send_goal_async(Fibonacci.Goal(order=6), feedback_callback=feedback.append)
    assert spin_until(executor, sent.done, 20)
    handle = sent.result()
    assert handle.accepted
    result = handle.get_result_async()
    assert spin_until(executor, result.done, 20)
    assert result.result().status == GoalStatus.STATUS_SUCCEEDED
    assert list(result.result().result.sequence) == [0, 1, 1, 2, 3, 5, 8]
    assert [list(f.feedback.sequence) for f in feedback][-1] == [0, 1, 1, 2, 3, 5, 8]
    assert all(bytes(f.goal_id.uuid) == bytes(handle.goal_id.uuid) for f in feedback)
    assert spin_until(executor, lambda: handle.status == GoalStatus.STATUS_SUCCEEDED, 5)

    # rejected by the goal callback
    sent = client.send_goal_async(Fibonacci.Goal(order=-1))
    assert spin_until(executor, sent.done, 20)
    assert not sent.result().accepted

    # cancelled while executing
    sent = client.send_goal_async(Fibonacci.Goal(order=40))
    assert spin_until(executor, sent.done, 20) and sent.result().accepted
    handle = sent.result()
    assert spin_until(executor, lambda: handle.status == GoalStatus.STATUS_EXECUTING, 10)
    cancel = handle.cancel_goal_async()
    assert spin_until(executor, cancel.done, 20)
    assert cancel.result().return_code == CancelGoal.Response.ERROR_NONE
    assert len(cancel.result().goals_canceling) == 1
    result = handle.get_result_async()
    assert spin_until(executor, result.done, 20)
    assert result.result().status == GoalStatus.STATUS_CANCELED
    assert server.read_until('CANCELED', 5)

    # cancelling a finished goal is refused as terminated; an unknown goal's result is UNKNOWN
    cancel = handle.cancel_goal_async()
    assert spin_until(executor, cancel.done, 20)
    assert cancel.result().return_code == CancelGoal.Response.ERROR_GOAL_TERMINATED
    client.destroy()
    node.destroy_node()


def test_status_array_fast_codec_equals_generic() -> None:
    import os

    from action_msgs.msg import GoalInfo, GoalStatus, GoalStatusArray
    from builtin_interfaces.msg import Time
    from rclpy.action.common import decode_status_array, encode_status_array
    from unique_identifier_msgs.msg import UUID

    from cage_ros_runtime import messages
    for n in (0, 1, 5):
        entries = [(os.urandom(16), 5 + i, 7 * i, i % 7) for i in range(n)]
        msg = GoalStatusArray(status_list=[GoalStatus(
            goal_info=GoalInfo(goal_id=UUID(uuid=list(u)), stamp=Time(sec=s, nanosec=ns)), status=st)
            for u, s, ns, st in entries])
        assert encode_status_array(entries) == messages.serialize(msg)
        assert decode_status_array(messages.serialize(msg)) == entries
