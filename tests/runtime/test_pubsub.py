"""Separate processes over real Cyclone DDS: exchange, latching, QoS compatibility, domain isolation."""

from __future__ import annotations

import pytest

from runtime_testlib import spin_until, unique_domain

pytestmark = pytest.mark.timeout(30)


def _executor(ctx, *nodes):
    from rclpy.executors import SingleThreadedExecutor
    ex = SingleThreadedExecutor(context=ctx)
    for n in nodes:
        ex.add_node(n)
    return ex


def _qos(reliable: bool, transient_local: bool, depth: int = 10):
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    return QoSProfile(depth=depth,
                      reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL if transient_local
                      else DurabilityPolicy.VOLATILE)


def test_two_processes_exchange_messages(context, spawn) -> None:
    from rclpy.node import Node
    from std_msgs.msg import String
    talker = spawn('talker.py', '--ros-args', '-p', 'text:=ping')
    node = Node('listener', context=context)
    got: list[str] = []
    node.create_subscription(String, 'chatter', lambda m: got.append(m.data), 10)
    assert spin_until(_executor(context, node), lambda: len(got) >= 5, 15.0), talker.output
    assert got[0].startswith('ping ')
    numbers = [int(s.split()[1]) for s in got]
    assert numbers == sorted(numbers)


def test_late_joiner_gets_latched_sample(context, spawn) -> None:
    from rclpy.node import Node
    from std_msgs.msg import String
    talker = spawn('talker.py', '--ros-args', '-p', 'latched:=true', '-p', 'text:=the map')
    assert talker.read_until('READY', 15.0), talker.output
    node = Node('late', context=context)  # created after the sample was published
    got: list[str] = []
    node.create_subscription(String, 'chatter', lambda m: got.append(m.data), _qos(True, True, 1))
    assert spin_until(_executor(context, node), lambda: got == ['the map'], 10.0), got


@pytest.mark.parametrize('talker_args, compatible, incompatible', [
    # a RELIABLE reader does not match a BEST_EFFORT writer
    (['--ros-args', '-p', 'reliable:=false'], (False, False), (True, False)),
    # a TRANSIENT_LOCAL reader does not match a VOLATILE writer
    ([], (True, False), (True, True)),
], ids=['reliable-vs-best-effort', 'transient-local-vs-volatile'])
def test_incompatible_reader_does_not_match(context, spawn, talker_args, compatible, incompatible) -> None:
    from rclpy.node import Node
    from std_msgs.msg import String
    spawn('talker.py', *talker_args)
    node = Node('qos_check', context=context)
    good: list[str] = []
    bad: list[str] = []
    node.create_subscription(String, 'chatter', lambda m: good.append(m.data), _qos(*compatible))
    sub = node.create_subscription(String, 'chatter', lambda m: bad.append(m.data), _qos(*incompatible))
    # the compatible reader proves the writer is discovered and sending
    assert spin_until(_executor(context, node), lambda: len(good) >= 5, 15.0)
    assert bad == []
    assert sub.get_publisher_count() == 0


def test_domains_are_isolated(context, spawn) -> None:
    import rclpy
    from rclpy.context import Context
    from rclpy.node import Node
    from rclpy.signals import SignalHandlerOptions
    from std_msgs.msg import String
    spawn('talker.py')  # in the test's domain (context's)
    other_ctx = Context()
    other_domain = unique_domain()
    assert other_domain != context.get_domain_id()
    rclpy.init(args=[], context=other_ctx, domain_id=other_domain,
               signal_handler_options=SignalHandlerOptions.NO)
    try:
        same, other = Node('same', context=context), Node('other', context=other_ctx)
        got_same: list[str] = []
        got_other: list[str] = []
        same.create_subscription(String, 'chatter', lambda m: got_same.append(m.data), 10)
        other.create_subscription(String, 'chatter', lambda m: got_other.append(m.data), 10)
        other_ex = _executor(other_ctx, other)
        ex = _executor(context, same)

        def both() -> bool:
            other_ex.spin_once(timeout_sec=0)
            return len(got_same) >= 5
        assert spin_until(ex, both, 15.0)
        assert got_other == []
    finally:
        other_ctx.try_shutdown()


def test_publisher_counts_and_raw_publish(context) -> None:
    from rclpy.node import Node
    from std_msgs.msg import String
    from cage_ros_runtime.messages import serialize
    node = Node('self_talk', context=context)
    pub = node.create_publisher(String, 'loop', 10)
    got: list[str] = []
    node.create_subscription(String, 'loop', lambda m: got.append(m.data), 10)
    from runtime_testlib import wait_until
    assert wait_until(lambda: pub.get_subscription_count() == 1, 5.0)
    pub.publish(String(data='typed'))
    pub.publish(serialize(String(data='raw')))
    with pytest.raises(TypeError):
        pub.publish('not a message')
    assert spin_until(_executor(context, node), lambda: got == ['typed', 'raw'], 5.0), got
