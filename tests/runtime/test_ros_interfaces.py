"""What every node offers a ROS 2 user, across real processes: parameter services (with the node's
on-set callback deciding), /parameter_events, /rosout (Jazzy QoS) and /clock-driven sim time."""

from __future__ import annotations

from typing import Any, Callable

from runtime_testlib import spin_until


def _call(executor: Any, client: Any, request: Any) -> Any:
    assert client.wait_for_service(timeout_sec=20), client.srv_name
    future = client.call_async(request)
    assert spin_until(executor, future.done, 20)
    return future.result()


def test_parameter_services_and_events(spawn: Callable[..., Any], context: Any) -> None:
    from rcl_interfaces.msg import Parameter as ParameterMsg
    from rcl_interfaces.msg import ParameterEvent, ParameterType, ParameterValue
    from rcl_interfaces.srv import (DescribeParameters, GetParameters, GetParameterTypes, ListParameters,
                                    SetParameters, SetParametersAtomically)
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node

    proc = spawn('param_node.py', '--ros-args', '-r', '__ns:=/cage')
    assert proc.read_until('READY', 60), proc.output
    node = Node('param_tool', context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    events: list = []
    node.create_subscription(ParameterEvent, '/parameter_events',
                             lambda e: events.append(e) if e.node == '/cage/param_node' else None, 100)
    base = '/cage/param_node/'

    listed = _call(executor, node.create_client(ListParameters, base + 'list_parameters'),
                   ListParameters.Request()).result
    assert {'speed', 'label', 'shield', 'gains', 'use_sim_time'} <= set(listed.names)
    got = _call(executor, node.create_client(GetParameters, base + 'get_parameters'),
                GetParameters.Request(names=['speed', 'label', 'gains', 'nope']))
    assert got.values[0].double_value == 1.0 and got.values[1].string_value == 'cage'
    assert list(got.values[2].double_array_value) == [0.5, 0.25]
    assert got.values[3].type == ParameterType.PARAMETER_NOT_SET
    types = _call(executor, node.create_client(GetParameterTypes, base + 'get_parameter_types'),
                  GetParameterTypes.Request(names=['shield', 'speed']))
    assert list(types.types) == [ParameterType.PARAMETER_BOOL, ParameterType.PARAMETER_DOUBLE]
    described = _call(executor, node.create_client(DescribeParameters, base + 'describe_parameters'),
                      DescribeParameters.Request(names=['label']))
    assert described.descriptors[0].name == 'label'
    assert described.descriptors[0].type == ParameterType.PARAMETER_STRING

    setter = node.create_client(SetParameters, base + 'set_parameters')
    ok, refused, wrong_type, undeclared = _call(executor, setter, SetParameters.Request(parameters=[
        ParameterMsg(name='speed', value=ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=2.5)),
        ParameterMsg(name='speed', value=ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=-1.0)),
        ParameterMsg(name='shield', value=ParameterValue(type=ParameterType.PARAMETER_STRING, string_value='x')),
        ParameterMsg(name='ghost', value=ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=True)),
    ])).results
    assert ok.successful and proc.read_until('SET speed=2.5', 10)
    assert not refused.successful and refused.reason == 'speed must not be negative'
    assert not wrong_type.successful and not undeclared.successful
    atomic = _call(executor, node.create_client(SetParametersAtomically, base + 'set_parameters_atomically'),
                   SetParametersAtomically.Request(parameters=[
                       ParameterMsg(name='shield', value=ParameterValue(type=ParameterType.PARAMETER_BOOL,
                                                                        bool_value=False))]))
    assert atomic.result.successful and proc.read_until('SET shield=False', 10)
    assert spin_until(executor, lambda: any(
        p.name == 'shield' and p.value.bool_value is False for e in events for p in e.changed_parameters), 10)
    node.destroy_node()


def test_rosout_carries_node_logs(spawn: Callable[..., Any], context: Any) -> None:
    """The node logged once at start; /rosout is transient local, so a late subscriber still gets it."""
    from rcl_interfaces.msg import Log
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.qos import qos_profile_rosout_default

    proc = spawn('param_node.py')
    assert proc.read_until('READY', 60), proc.output
    assert qos_profile_rosout_default.lifespan.nanoseconds == 10 * 10**9
    node = Node('log_reader', context=context)
    logs: list = []
    node.create_subscription(Log, '/rosout', logs.append, qos_profile_rosout_default)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    assert spin_until(executor, lambda: any(m.msg == 'hello rosout' for m in logs), 20)
    line = next(m for m in logs if m.msg == 'hello rosout')
    assert line.name == 'param_node' and line.level == Log.INFO and line.function == '__init__'
    node.destroy_node()


def test_clock_drives_sim_time_and_timers(spawn: Callable[..., Any], context: Any) -> None:
    """With use_sim_time the node's clock and its 0.5 s timer follow /clock, not the wall clock."""
    from builtin_interfaces.msg import Time
    from rclpy.node import Node
    from rosgraph_msgs.msg import Clock

    proc = spawn('param_node.py', '--ros-args', '-p', 'use_sim_time:=true')
    assert proc.read_until('READY', 60), proc.output
    node = Node('clock_pub', context=context)
    pub = node.create_publisher(Clock, '/clock', 10)
    import time
    deadline = time.monotonic() + 20
    while pub.get_subscription_count() == 0 and time.monotonic() < deadline:
        time.sleep(0.02)
    for step in range(1, 41):  # 100 s .. 104 s of sim time in 0.1 s steps, fast in wall time
        pub.publish(Clock(clock=Time(sec=100 + step // 10, nanosec=(step % 10) * 100_000_000)))
        time.sleep(0.01)
    assert proc.read_until('TICK 10', 20), proc.output
    proc.read_until('TICK 1035', 5)  # the tick at 103.5 s of sim time, or whatever came in 5 s
    ticks = [int(line.split()[1]) for line in proc.lines if line.startswith('TICK')]
    assert ticks and all(100 * 10**9 <= t <= 104 * 10**9 for t in ticks), proc.output
    assert len(ticks) >= 4, proc.output  # 4 s of sim time in about 0.5 s of wall time: at least 4 half-second ticks
    node.destroy_node()
