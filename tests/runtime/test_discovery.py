"""Discovery range as rmw_cyclonedds_cpp (Jazzy) maps it, and the first graph query seeing remote nodes."""

from __future__ import annotations

from typing import Any, Callable

from cage_ros_runtime.discovery import DiscoveryOptions, cyclone_config, domain_config, from_environment


def test_environment_is_read_as_rcl_reads_it() -> None:
    assert from_environment({}) == DiscoveryOptions('SUBNET', [])
    assert from_environment({'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
                             'ROS_STATIC_PEERS': 'a.example;192.168.0.7'}) == \
        DiscoveryOptions('LOCALHOST', ['a.example', '192.168.0.7'])
    assert from_environment({'ROS_AUTOMATIC_DISCOVERY_RANGE': 'OFF', 'ROS_STATIC_PEERS': 'x'}) == \
        DiscoveryOptions('OFF', [])
    assert from_environment({'ROS_LOCALHOST_ONLY': '1', 'ROS_STATIC_PEERS': 'x'}) == \
        DiscoveryOptions('LOCALHOST', [])
    assert from_environment({'ROS_AUTOMATIC_DISCOVERY_RANGE': 'bogus'}).automatic_range == 'LOCALHOST'


def test_cyclone_config_as_rmw_cyclonedds() -> None:
    assert cyclone_config(DiscoveryOptions('SUBNET', [])) == ''
    assert cyclone_config(DiscoveryOptions('SYSTEM_DEFAULT', ['x'])) == ''
    assert cyclone_config(DiscoveryOptions('LOCALHOST', ['10.0.0.2'])) == (
        '<CycloneDDS><Domain><General><AllowMulticast>false</AllowMulticast></General>'
        '<Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>32'
        '</MaxAutoParticipantIndex><Peers><Peer address="localhost"/><Peer address="10.0.0.2"/></Peers>'
        '</Discovery></Domain></CycloneDDS>')
    assert cyclone_config(DiscoveryOptions('OFF', []), pid=42) == (
        '<CycloneDDS><Domain><General><AllowMulticast>false</AllowMulticast></General>'
        '<Discovery><ParticipantIndex>none</ParticipantIndex><Tag>ros_discovery_off_42</Tag>'
        '</Discovery></Domain></CycloneDDS>')
    assert cyclone_config(DiscoveryOptions('SUBNET', ['h'])).endswith(
        '<Peers><Peer address="h"/></Peers></Discovery></Domain></CycloneDDS>')
    assert domain_config({'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST', 'CYCLONEDDS_URI': 'file:///c.xml'}) \
        .endswith('</CycloneDDS>,file:///c.xml')


def _listen(context: Any, seconds: float) -> list:
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from std_msgs.msg import String

    from runtime_testlib import spin_until
    node = Node('listener', context=context)
    got: list = []
    node.create_subscription(String, 'chatter', lambda m: got.append(m.data), 10)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    spin_until(executor, lambda: bool(got), seconds)
    node.destroy_node()
    return got


def test_localhost_only_discovery_finds_peers(spawn: Callable[..., Any], ros_env: dict, monkeypatch: Any,
                                              context: Any) -> None:
    env = dict(ros_env, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    talker = spawn('talker.py', env=env)
    assert talker.read_until('READY', 60), talker.output
    monkeypatch.setenv('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    assert _listen(context, 20)


def test_discovery_off_finds_nobody(spawn: Callable[..., Any], ros_env: dict, monkeypatch: Any,
                                    context: Any) -> None:
    talker = spawn('talker.py', env=dict(ros_env, ROS_AUTOMATIC_DISCOVERY_RANGE='OFF'))
    assert talker.read_until('READY', 60), talker.output
    monkeypatch.setenv('ROS_AUTOMATIC_DISCOVERY_RANGE', 'OFF')
    assert _listen(context, 2.0) == []


def test_first_graph_query_sees_remote_nodes(spawn: Callable[..., Any], context: Any) -> None:
    from rclpy.node import Node
    talker = spawn('talker.py', '--ros-args', '-r', '__ns:=/remote')
    assert talker.read_until('READY', 60), talker.output
    node = Node('asker', context=context)
    assert ('talker', '/remote') in node.get_node_names_and_namespaces()  # the very first query
    node.destroy_node()


def test_best_available_subscription_gets_latched_data(spawn: Callable[..., Any], context: Any) -> None:
    """BEST_AVAILABLE resolves to what the publisher offers (reliable + transient local here)."""
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.qos import ReliabilityPolicy, qos_profile_best_available
    from std_msgs.msg import String

    from runtime_testlib import spin_until
    talker = spawn('talker.py', '--ros-args', '-p', 'latched:=true', '-p', 'text:=the map')
    assert talker.read_until('READY', 60), talker.output
    node = Node('late', context=context)
    assert spin_until(SingleThreadedExecutor(context=context), lambda: node.count_publishers('chatter') > 0, 20)
    got: list = []
    sub = node.create_subscription(String, 'chatter', lambda m: got.append(m.data), qos_profile_best_available)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    assert spin_until(executor, lambda: got == ['the map'], 20)
    assert sub.qos_profile.reliability == ReliabilityPolicy.BEST_AVAILABLE  # the user's profile is kept
    node.destroy_node()
