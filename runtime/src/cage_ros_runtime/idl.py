"""Cyclone DDS topic types that mirror ROS messages, named exactly as rmw_cyclonedds_cpp names them.

Why a mirror type at all when the runtime writes pre-serialized bytes: the `cyclonedds` Python binding
normalizes (validates, and byte-swaps to native order) every sample against the topic's type description,
both on write and on receive, so the DDS topic type must have the very same layout as the ROS message.  Its
type name (`pkg::msg::dds_::Name_`, nested types included) is what Cyclone matches against rmw_cyclonedds
endpoints: rmw_cyclonedds advertises no XTypes type information, and Cyclone then falls back to comparing
type names (XTypes 7.6.3.4.2; `force_type_validation` is off by default).  Between two processes of this
runtime, both sides do carry type information and Cyclone checks assignability, which holds trivially.
"""

from __future__ import annotations

import functools

from cyclonedds.idl import IdlStruct, make_idl_struct
from cyclonedds.idl import types as t
from rosbags.typesys.base import Nodetype

from cage_ros_runtime.typestore import dds_type_name, typestore

_BASE = {
    'bool': bool, 'byte': t.byte, 'char': t.uint8, 'int8': t.int8, 'uint8': t.uint8,
    'int16': t.int16, 'uint16': t.uint16, 'int32': t.int32, 'uint32': t.uint32,
    'int64': t.int64, 'uint64': t.uint64, 'float32': t.float32, 'float64': t.float64,
}


def _member_type(desc: tuple) -> object:
    kind, arg = desc
    if kind == Nodetype.BASE:
        base, bound = arg
        if base == 'string':
            return t.bounded_str[bound] if bound else str
        if base == 'wstring':
            raise TypeError('wstring members are not supported by this runtime')
        return _BASE[base]
    if kind == Nodetype.NAME:
        return idl_type(arg)
    sub, n = arg
    if kind == Nodetype.ARRAY:
        return t.array[_member_type(sub), n]
    return t.sequence[_member_type(sub), n] if n else t.sequence[_member_type(sub)]


@functools.lru_cache(maxsize=None)
def idl_type(ros_type: str, request_header: bool = False) -> type[IdlStruct]:
    """The Cyclone topic type for `pkg/msg/Name` (cached; nested types are shared).

    With `request_header`, the type of a service request/reply topic: rmw_cyclonedds puts its
    `cdds_request_header_t` (uint64 client writer id, int64 sequence number) in front of the message in
    the same CDR stream, under the message's own type name.
    """
    _, fielddefs = typestore().fielddefs[ros_type]
    members: dict = {'rmw_request_guid': t.uint64, 'rmw_request_seq': t.int64} if request_header else {}
    members.update({name: _member_type(desc) for name, desc in fielddefs})
    class_name = dds_type_name(ros_type).replace('::', '_') + ('_rq' if request_header else '')
    return make_idl_struct(class_name, dds_type_name(ros_type), members)
