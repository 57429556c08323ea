"""Message classes and CDR: bytes equal to rosbags' independent serializer, round trips, rclpy semantics."""

from __future__ import annotations

import array
import random
from pathlib import Path

import numpy as np
import pytest
from rosbags.typesys.base import Nodetype

from cage_ros_runtime import messages
from cage_ros_runtime.messages import EMPTY_MEMBER, message_class
from cage_ros_runtime.typestore import field_defaults, typestore

pytestmark = pytest.mark.timeout(60)

MSG_DIR = Path(__file__).resolve().parents[2] / 'ros2_ws' / 'src' / 'cage_planner_msgs' / 'msg'
CAGE_TYPES = sorted(f'cage_planner_msgs/msg/{p.stem}' for p in MSG_DIR.glob('*.msg'))
STANDARD_TYPES = [
    'sensor_msgs/msg/LaserScan', 'nav_msgs/msg/Path', 'geometry_msgs/msg/PoseStamped',
    'nav_msgs/msg/Odometry', 'visualization_msgs/msg/MarkerArray', 'visualization_msgs/msg/Marker',
    'tf2_msgs/msg/TFMessage', 'std_msgs/msg/Header', 'std_msgs/msg/Empty', 'std_msgs/msg/String',
    'std_msgs/msg/Float64', 'std_msgs/msg/Bool', 'builtin_interfaces/msg/Time',
    'geometry_msgs/msg/Twist', 'geometry_msgs/msg/Point', 'rosgraph_msgs/msg/Clock',
    'rmw_dds_common/msg/ParticipantEntitiesInfo', 'sensor_msgs/msg/Image',
]
ALL_TYPES = STANDARD_TYPES + CAGE_TYPES

_INT_RANGE = {'int8': (-128, 127), 'uint8': (0, 255), 'byte': (0, 255), 'char': (0, 255),
              'int16': (-2**15, 2**15 - 1), 'uint16': (0, 2**16 - 1), 'int32': (-2**31, 2**31 - 1),
              'uint32': (0, 2**32 - 1), 'int64': (-2**63, 2**63 - 1), 'uint64': (0, 2**64 - 1)}


def _random_value(rng: random.Random, base: str):
    if base == 'string':
        return ''.join(rng.choice('abcxyz/_ ') for _ in range(rng.randint(0, 9)))
    if base == 'bool':
        return rng.random() < 0.5
    if base == 'float32':
        return float(np.float32(rng.uniform(-1e3, 1e3)))
    if base == 'float64':
        return rng.uniform(-1e6, 1e6)
    lo, hi = _INT_RANGE[base]
    return rng.randint(lo, hi)


def random_tree(ros_type: str, rng: random.Random, depth: int = 0) -> dict:
    """Plain values for every field (sequences of 0..3 items, nested types too)."""
    out = {}
    for name, (kind, arg) in typestore().fielddefs[ros_type][1]:
        if name == EMPTY_MEMBER:
            continue
        if kind == Nodetype.BASE:
            out[name] = _random_value(rng, arg[0])
        elif kind == Nodetype.NAME:
            out[name] = random_tree(arg, rng, depth + 1)
        else:
            (sub_kind, sub_arg), n = arg
            count = n if kind == Nodetype.ARRAY else rng.randint(0 if depth else 1, 3 if depth < 3 else 0)
            if sub_kind == Nodetype.BASE:
                out[name] = [_random_value(rng, sub_arg[0]) for _ in range(count)]
            else:
                out[name] = [random_tree(sub_arg, rng, depth + 1) for _ in range(count)]
    return out


def build_runtime(ros_type: str, tree: dict):
    """The runtime's class, filled with plain Python lists (what node code does)."""
    msg = message_class(ros_type)()
    for f in msg._fields:
        value = tree[f.name]
        if f.kind == Nodetype.NAME:
            value = build_runtime(f.ref, value)
        elif f.ref is not None:
            value = [build_runtime(f.ref, v) for v in value]
        setattr(msg, f.name, value)
    return msg


def build_rosbags(ros_type: str, tree: dict):
    """The same values as rosbags' own dataclasses (numpy arrays for numeric arrays/sequences)."""
    store = typestore()
    kwargs = {}
    for name, (kind, arg) in store.fielddefs[ros_type][1]:
        if name == EMPTY_MEMBER:
            kwargs[name] = 0
            continue
        value = tree[name]
        if kind == Nodetype.NAME:
            value = build_rosbags(arg, value)
        elif kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
            (sub_kind, sub_arg), _n = arg
            if sub_kind == Nodetype.NAME:
                value = [build_rosbags(sub_arg, v) for v in value]
            elif sub_arg[0] != 'string':
                dtype = {'char': 'uint8', 'byte': 'uint8', 'bool': 'bool'}.get(sub_arg[0], sub_arg[0])
                value = np.array(value, dtype=dtype)
        kwargs[name] = value
    return store.types[ros_type](**kwargs)


def test_project_messages_found() -> None:
    assert {'cage_planner_msgs/msg/HeadingSetpoint', 'cage_planner_msgs/msg/PlannerStatus',
            'cage_planner_msgs/msg/CageMap', 'cage_planner_msgs/msg/MissionEvent'} <= set(CAGE_TYPES)


@pytest.mark.parametrize('ros_type', ALL_TYPES)
def test_bytes_equal_rosbags_and_round_trip(ros_type: str) -> None:
    rng = random.Random(ros_type)
    for _ in range(3):
        tree = random_tree(ros_type, rng)
        msg = build_runtime(ros_type, tree)
        ours = messages.serialize(msg)
        reference = bytes(typestore().serialize_cdr(build_rosbags(ros_type, tree), ros_type))
        assert ours == reference
        assert ours[:4] == b'\x00\x01\x00\x00'
        back = messages.deserialize(ours, ros_type)
        assert back == msg
        assert messages.serialize(back) == ours


@pytest.mark.parametrize('ros_type', ALL_TYPES)
def test_default_message_matches_jazzy_defaults(ros_type: str) -> None:
    """Defaults are zero/empty except where the .msg file gives one (Quaternion's w = 1.0, as Jazzy)."""
    msg = message_class(ros_type)()
    zero = build_rosbags(ros_type, _zero_tree(ros_type))
    assert messages.serialize(msg) == bytes(typestore().serialize_cdr(zero, ros_type))


def _zero_tree(ros_type: str) -> dict:
    out = {}
    defaults = field_defaults(ros_type)
    for name, (kind, arg) in typestore().fielddefs[ros_type][1]:
        if name == EMPTY_MEMBER:
            continue
        if name in defaults:
            out[name] = defaults[name]
        elif kind == Nodetype.BASE:
            out[name] = '' if arg[0] == 'string' else (False if arg[0] == 'bool' else 0)
        elif kind == Nodetype.NAME:
            out[name] = _zero_tree(arg)
        elif kind == Nodetype.ARRAY:
            (sub_kind, sub_arg), n = arg
            if sub_kind == Nodetype.NAME:
                out[name] = [_zero_tree(sub_arg) for _ in range(n)]
            else:
                out[name] = ['' if sub_arg[0] == 'string' else 0] * n
        else:
            out[name] = []
    return out


def test_golden_bytes_header_and_empty() -> None:
    from builtin_interfaces.msg import Time
    from std_msgs.msg import Empty, Header
    header = Header(stamp=Time(sec=1, nanosec=2), frame_id='map')
    assert messages.serialize(header) == bytes.fromhex('00010000010000000200000004000000') + b'map\x00'
    assert messages.serialize(Empty()) == b'\x00\x01\x00\x00\x00'


def test_big_endian_payload_is_read() -> None:
    from builtin_interfaces.msg import Time
    from std_msgs.msg import Header
    be = bytes.fromhex('00000000000000010000000200000004') + b'map\x00'
    assert messages.deserialize(be, 'std_msgs/msg/Header') == Header(stamp=Time(sec=1, nanosec=2),
                                                                      frame_id='map')


def test_rclpy_style_classes() -> None:
    from cage_planner_msgs.msg import HeadingSetpoint, PlannerStatus
    from geometry_msgs.msg import PoseWithCovariance
    from sensor_msgs.msg import LaserScan
    from std_msgs.msg import Header

    assert PlannerStatus.NO_VALID_PATH == 6 and HeadingSetpoint.SOURCE_FAILSAFE == 2
    sp = HeadingSetpoint(heading=1.5, decision=3)
    assert sp.header == Header() and sp.speed == 0.0 and sp.source == 0
    sp.header.frame_id = 'map'
    assert sp.header.frame_id == 'map'
    with pytest.raises(AttributeError):
        sp.not_a_field = 1
    with pytest.raises(AssertionError):
        HeadingSetpoint(nonsense=1)

    scan = LaserScan()
    assert isinstance(scan.ranges, array.array) and len(scan.ranges) == 0
    data = []
    for ranges in ([1.0, 2.0], (1.0, 2.0), np.array([1.0, 2.0]), array.array('f', [1.0, 2.0])):
        scan.ranges = ranges
        data.append(messages.serialize(scan))
    assert len(set(data)) == 1
    assert messages.deserialize(data[0], 'sensor_msgs/msg/LaserScan').ranges == array.array('f', [1, 2])

    cov = PoseWithCovariance()
    assert isinstance(cov.covariance, np.ndarray) and cov.covariance.shape == (36,)
    cov.covariance = [0.0] * 35
    with pytest.raises(ValueError):
        messages.serialize(cov)
    assert 'cage_planner_msgs.msg.HeadingSetpoint(' in repr(sp)
    assert HeadingSetpoint.get_fields_and_field_types()['header'] == 'std_msgs/Header'
    assert LaserScan.get_fields_and_field_types()['ranges'] == 'sequence<float>'
    assert HeadingSetpoint(heading=1.0) != HeadingSetpoint(heading=2.0)


def test_dds_type_names() -> None:
    from cage_ros_runtime.idl import idl_type
    from cage_ros_runtime.typestore import dds_type_name, ros_type_name
    assert dds_type_name('sensor_msgs/msg/LaserScan') == 'sensor_msgs::msg::dds_::LaserScan_'
    assert ros_type_name('cage_planner_msgs::msg::dds_::HeadingSetpoint_') == \
        'cage_planner_msgs/msg/HeadingSetpoint'
    assert idl_type('sensor_msgs/msg/LaserScan').__idl_typename__ == 'sensor_msgs::msg::dds_::LaserScan_'


def test_quaternion_default_is_identity_as_in_jazzy() -> None:
    from geometry_msgs.msg import Pose, Quaternion
    assert Quaternion().w == 1.0 and Pose().orientation == Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)


def test_byte_is_unsigned_both_ways() -> None:
    from std_msgs.msg import Byte
    data = messages.serialize(Byte(data=200))
    assert data[4] == 200
    assert messages.deserialize(data, 'std_msgs/msg/Byte').data == 200
    with pytest.raises(ValueError, match='byte'):
        messages.serialize(Byte(data=256))
