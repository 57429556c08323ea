"""Services and actions expanded as rosidl does: names, classes and RIHS01 hashes equal Jazzy's.

The golden hashes are the ones Jazzy advertises (published in several independent ROS 2 client
implementations): they only come out right if the expansion (Request/Response/Event, SendGoal/GetResult,
FeedbackMessage) and the msg `char` -> `uint8` mapping are rosidl's.
"""

from __future__ import annotations

from rosbags.typesys import Stores, get_typestore

from cage_ros_runtime import interfaces
from cage_ros_runtime.msgpkg import interface_class
from cage_ros_runtime.typestore import type_hash

JAZZY_HASHES = {
    # ros_discovery_info: rmw_dds_common/Gid is `char[16]`, hashed as uint8[16] by rosidl
    'rmw_dds_common/msg/ParticipantEntitiesInfo':
        'RIHS01_91a0593bacdcc50ea9bdcf849a938b128412cc1ea821245c663bcd26f83c295e',
    'rcl_interfaces/srv/GetParameters':
        'RIHS01_bf9803d5c74cf989a5de3e0c2e99444599a627c7ff75f97b8c05b01003675cbc',
    'rcl_interfaces/srv/ListParameters':
        'RIHS01_3e6062bfbb27bfb8730d4cef2558221f51a11646d78e7bb30a1e83afac3aad9d',
    'rcl_interfaces/srv/SetParameters':
        'RIHS01_56eed9a67e169f9cb6c1f987bc88f868c14a8fc9f743a263bc734c154015d7e0',
    'rcl_interfaces/srv/GetParameterTypes':
        'RIHS01_da199c878688b3e530bdfe3ca8f74cb9fa0c303101e980a9e8f260e25e1c80ca',
    'action_msgs/srv/CancelGoal':
        'RIHS01_573d8b0a534451d7bc2ac8c5ffde8ac14b8593b7001175d0cd6516dcbeb8689a',
    'example_interfaces/srv/AddTwoInts':
        'RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a',
    'action_msgs/msg/GoalStatusArray':
        'RIHS01_6c1684b00f177d37438febe6e709fc4e2b0d4248dca4854946f9ed8b30cda83e',
}

FIBONACCI = 'int32 order\n---\nint32[] sequence\n---\nint32[] partial_sequence\n'


def test_standard_hashes_equal_jazzy() -> None:
    for ros_type, expected in JAZZY_HASHES.items():
        assert type_hash(ros_type) == expected, ros_type


def test_char_hashes_as_uint8() -> None:
    hashes = []
    for text in ('char c\nchar[4] cs\n', 'uint8 c\nuint8[4] cs\n'):
        store = get_typestore(Stores.ROS2_JAZZY)
        store.register(interfaces.expand('hash_demo', 'msg', 'Chars', text)[0])
        interfaces.chars_as_uint8(store)
        hashes.append(store.hash_rihs01('hash_demo/msg/Chars'))
    assert hashes[0] == hashes[1]


def test_action_expansion_equals_rosidl() -> None:
    """action_tutorials_interfaces/Fibonacci: the feedback message hash Jazzy advertises."""
    store = get_typestore(Stores.ROS2_JAZZY)
    types, _ = interfaces.expand('action_tutorials_interfaces', 'action', 'Fibonacci', FIBONACCI)
    store.register(types)
    assert store.hash_rihs01('action_tutorials_interfaces/action/Fibonacci_FeedbackMessage') == \
        'RIHS01_50fc26b9cac313652ecbeab3adf9b5414d59fd4d4d5f9058ddcc7525169927f1'


def test_service_and_action_classes_have_rclpy_surface() -> None:
    from action_msgs.srv import CancelGoal
    from std_srvs.srv import SetBool
    assert SetBool.Request(data=True).data is True and SetBool.Response().message == ''
    assert SetBool.Event().request == [] and CancelGoal.Response.ERROR_UNKNOWN_GOAL_ID == 2
    assert interface_class('std_srvs/srv/SetBool') is SetBool
    store_types, defaults = interfaces.expand('demo', 'action', 'Go', 'float64 x 2.5\n---\nint8 code\n---\n')
    assert defaults == {'demo/action/Go_Goal': {'x': 2.5}}
    assert [f for f, _ in store_types['demo/action/Go_SendGoal_Request'][1]] == ['goal_id', 'goal']
    assert [f for f, _ in store_types['demo/action/Go_GetResult_Response'][1]] == ['status', 'result']
