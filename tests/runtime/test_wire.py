"""What other DDS participants (e.g. rmw_cyclonedds_cpp) discover about our endpoints."""

from __future__ import annotations

import pytest

from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsParticipant, BuiltinTopicDcpsPublication, \
    BuiltinTopicDcpsSubscription
from cyclonedds.domain import DomainParticipant
from cyclonedds.qos import Policy

from cage_ros_runtime.typestore import type_hash
from runtime_testlib import wait_until

pytestmark = pytest.mark.timeout(30)


def _find(reader, topic: str):
    found = []

    def poll() -> bool:
        found[:] = [s for s in reader.read(N=1000) if s.topic_name == topic]
        return bool(found)
    assert wait_until(poll, 5.0), f'{topic} not discovered'
    return found[0]


def test_names_types_qos_and_user_data(context) -> None:
    from rclpy.node import Node
    from rclpy.qos import DurabilityPolicy, QoSProfile, qos_profile_sensor_data
    from cage_planner_msgs.msg import CageMap
    from sensor_msgs.msg import LaserScan

    node = Node('wire', namespace='cage', context=context)
    node.create_publisher(LaserScan, 'scan', qos_profile_sensor_data)
    node.create_publisher(CageMap, 'map', QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    node.create_subscription(LaserScan, '~/in', lambda m: None, 7)

    observer = DomainParticipant(context.get_domain_id())
    pubs = BuiltinDataReader(observer, BuiltinTopicDcpsPublication)
    subs = BuiltinDataReader(observer, BuiltinTopicDcpsSubscription)

    scan = _find(pubs, 'rt/cage/scan')
    assert scan.type_name == 'sensor_msgs::msg::dds_::LaserScan_'
    assert scan.qos[Policy.Reliability] == Policy.Reliability.BestEffort
    assert scan.qos[Policy.Durability] == Policy.Durability.Volatile
    assert scan.qos[Policy.History] == Policy.History.KeepLast(5)
    assert scan.qos[Policy.Userdata].data == f'typehash={type_hash("sensor_msgs/msg/LaserScan")};'.encode()
    assert scan.qos[Policy.Userdata].data.startswith(b'typehash=RIHS01_')
    assert scan.qos[Policy.DataRepresentation].use_cdrv0_representation
    assert not scan.qos[Policy.DataRepresentation].use_xcdrv2_representation

    cage_map = _find(pubs, 'rt/cage/map')
    assert cage_map.type_name == 'cage_planner_msgs::msg::dds_::CageMap_'
    assert isinstance(cage_map.qos[Policy.Reliability], Policy.Reliability.Reliable)
    assert cage_map.qos[Policy.Durability] == Policy.Durability.TransientLocal
    assert cage_map.qos[Policy.History] == Policy.History.KeepLast(1)

    private = _find(subs, 'rt/cage/wire/in')
    assert private.type_name == 'sensor_msgs::msg::dds_::LaserScan_'
    assert private.qos[Policy.History] == Policy.History.KeepLast(7)
    assert isinstance(private.qos[Policy.Reliability], Policy.Reliability.Reliable)

    ppants = BuiltinDataReader(observer, BuiltinTopicDcpsParticipant)
    ours = []
    assert wait_until(lambda: bool(ours.extend(
        p for p in ppants.read(N=100) if p.key.bytes == node._domain.gid) or ours), 5.0)
    assert ours[0].qos[Policy.Userdata].data == b'enclave=/;'
    node.destroy_node()


def test_ros_discovery_info_lists_nodes(context) -> None:
    from rclpy.node import Node
    from std_msgs.msg import String
    node = Node('announced', namespace='/cage/sub', context=context)
    node.create_publisher(String, 'x', 1)
    other = Node('second', context=context)
    assert wait_until(lambda: ('/cage/sub', 'announced') in node._observer().nodes()
                      and ('/', 'second') in node._observer().nodes(), 5.0)
    other.destroy_node()
    node.destroy_node()
