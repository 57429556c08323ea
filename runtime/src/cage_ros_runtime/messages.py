"""rclpy-style message classes generated from the type store, and their CDR codec.

Why generated on top of rosbags: rosbags' own dataclasses need every field and numpy arrays, while ROS node
code relies on rclpy's generated classes: every field defaults to zero/empty (nested messages included),
keyword construction, attribute assignment of plain lists, tuples or numpy arrays, constants as class
attributes, `__eq__` and a readable `__repr__`.  The wire encoding is delegated to rosbags' CDR serializer
(XCDR1, the same bytes rmw_cyclonedds_cpp sends); this module only converts between the two object models.

Defaults are rosidl's: zero/empty unless the interface file gives a default (`float64 w 1.0` in
geometry_msgs/Quaternion), see :func:`cage_ros_runtime.typestore.field_defaults`.

Deliberate simplifications against rclpy (documented in runtime/README.md):
- no per-assignment type checks; a wrong value is reported when the message is serialized (publish);
- `char` and `byte` fields are plain ints 0..255 (rclpy: str of length 1 / bytes of length 1); `byte` is
  unsigned on both sides (rosbags' codec reads it as int8, converted here);
- after deserialization numeric sequences are `array.array` and fixed-size numeric arrays `numpy.ndarray`
  (as in rclpy); `bool[]` and `string[]` are lists.
"""

from __future__ import annotations

import array
import functools
from typing import Any

import numpy as np
from rosbags.typesys.base import Nodetype

from cage_ros_runtime.typestore import field_defaults, typestore

#: rosbags' placeholder member of empty messages (rosidl adds one too); hidden from the Python API.
EMPTY_MEMBER = 'structure_needs_at_least_one_member'

_NUMPY_DTYPE = {
    'bool': np.bool_, 'byte': np.uint8, 'char': np.uint8, 'int8': np.int8, 'uint8': np.uint8,
    'int16': np.int16, 'uint16': np.uint16, 'int32': np.int32, 'uint32': np.uint32,
    'int64': np.int64, 'uint64': np.uint64, 'float32': np.float32, 'float64': np.float64,
}
_ARRAY_TYPECODE = {
    'byte': 'B', 'char': 'B', 'int8': 'b', 'uint8': 'B', 'int16': 'h', 'uint16': 'H',
    'int32': 'i', 'uint32': 'I', 'int64': 'q', 'uint64': 'Q', 'float32': 'f', 'float64': 'd',
}
_IDL_NAME = {
    'bool': 'boolean', 'byte': 'octet', 'char': 'uint8', 'float32': 'float', 'float64': 'double',
    'string': 'string',
}


class Field:
    """One member of a message type, with what is needed to default, convert and describe it."""

    __slots__ = ('name', 'kind', 'base', 'bound', 'length', 'ref', 'explicit')

    def __init__(self, name: str, desc: tuple, explicit: Any = None) -> None:
        self.name = name
        self.explicit = explicit       # default written in the interface file, if any
        self.kind, arg = desc
        self.base: str | None = None   # primitive name for BASE and for ARRAY/SEQUENCE of BASE
        self.ref: str | None = None    # message type for NAME and for ARRAY/SEQUENCE of NAME
        self.bound = 0                 # string bound / sequence bound
        self.length = 0                # fixed array length
        if self.kind == Nodetype.BASE:
            self.base, self.bound = arg
        elif self.kind == Nodetype.NAME:
            self.ref = arg
        else:
            (sub_kind, sub_arg), n = arg
            if self.kind == Nodetype.ARRAY:
                self.length = n
            else:
                self.bound = n
            if sub_kind == Nodetype.BASE:
                self.base = sub_arg[0]
            else:
                self.ref = sub_arg

    @property
    def numeric(self) -> bool:
        return self.base is not None and self.base != 'string'

    def default(self) -> Any:
        """The rclpy default for this member (fresh object every call)."""
        if self.explicit is not None:
            return self._explicit_default()
        if self.kind == Nodetype.BASE:
            if self.base == 'string':
                return ''
            if self.base == 'bool':
                return False
            return 0.0 if self.base.startswith('float') else 0
        if self.kind == Nodetype.NAME:
            return message_class(self.ref)()
        if self.kind == Nodetype.ARRAY:
            if self.ref is not None:
                return [message_class(self.ref)() for _ in range(self.length)]
            if self.base == 'string':
                return [''] * self.length
            return np.zeros(self.length, dtype=_NUMPY_DTYPE[self.base])
        if self.ref is not None or self.base in ('string', 'bool'):
            return []
        return array.array(_ARRAY_TYPECODE[self.base])

    def _explicit_default(self) -> Any:
        value = self.explicit
        if self.kind == Nodetype.BASE:
            return value
        if self.kind == Nodetype.ARRAY and self.base not in (None, 'string'):
            return np.array(value, dtype=_NUMPY_DTYPE[self.base])
        if self.base in (None, 'string', 'bool'):
            return list(value)
        return array.array(_ARRAY_TYPECODE[self.base], value)

    def type_string(self) -> str:
        """rclpy's `get_fields_and_field_types()` spelling, e.g. `sequence<float>` or `std_msgs/Header`."""
        if self.ref is not None:
            pkg, _, name = self.ref.split('/')
            inner = f'{pkg}/{name}'
        else:
            inner = _IDL_NAME.get(self.base, self.base)
            if self.base == 'string' and self.bound and self.kind == Nodetype.BASE:
                inner = f'string<{self.bound}>'
        if self.kind == Nodetype.ARRAY:
            return f'{inner}[{self.length}]'
        if self.kind == Nodetype.SEQUENCE:
            return f'sequence<{inner}, {self.bound}>' if self.bound else f'sequence<{inner}>'
        return inner


def _values_equal(a: Any, b: Any) -> bool:
    if isinstance(a, (np.ndarray, array.array)) or isinstance(b, (np.ndarray, array.array)):
        try:
            return len(a) == len(b) and bool(np.array_equal(np.asarray(a), np.asarray(b)))
        except TypeError:
            return False
    return a == b


class Message:
    """Base of all generated message classes (rclpy's generated classes have the same surface)."""

    __slots__ = ()
    _type: str = ''
    _fields: tuple[Field, ...] = ()
    _field_names: frozenset[str] = frozenset()

    def __init__(self, **kwargs: Any) -> None:
        unknown = set(kwargs) - self._field_names
        assert not unknown, f'Invalid arguments passed to constructor: {", ".join(sorted(unknown))}'
        for f in self._fields:
            object.__setattr__(self, f.name, kwargs[f.name] if f.name in kwargs else f.default())

    @classmethod
    def get_fields_and_field_types(cls) -> dict[str, str]:
        return {f.name: f.type_string() for f in cls._fields}

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, self.__class__):
            return False
        return all(_values_equal(getattr(self, f.name), getattr(other, f.name)) for f in self._fields)

    __hash__ = None  # mutable, like rclpy's messages

    def __repr__(self) -> str:
        pkg, kind, name = self._type.split('/')
        args = ', '.join(f'{f.name}={getattr(self, f.name)!r}' for f in self._fields)
        return f'{pkg}.{kind}.{name}({args})'

    def __copy__(self) -> 'Message':
        new = self.__class__.__new__(self.__class__)
        for f in self._fields:
            object.__setattr__(new, f.name, getattr(self, f.name))
        return new


@functools.lru_cache(maxsize=None)
def message_class(ros_type: str) -> type[Message]:
    """The generated class for `pkg/msg/Name` (cached: one class object per type per process)."""
    store = typestore()
    if ros_type not in store.fielddefs:
        raise ImportError(f'unknown message type {ros_type!r}')
    consts, fielddefs = store.fielddefs[ros_type]
    defaults = field_defaults(ros_type)
    fields = tuple(Field(name, desc, defaults.get(name)) for name, desc in fielddefs if name != EMPTY_MEMBER)
    pkg, kind, name = ros_type.split('/')
    namespace: dict[str, Any] = {
        '__slots__': tuple(f.name for f in fields),
        '__module__': f'{pkg}.{kind}',
        '__qualname__': name,
        '_type': ros_type,
        '_fields': fields,
        '_field_names': frozenset(f.name for f in fields),
        '_has_empty_member': len(fields) != len(fielddefs),
    }
    for cname, _ctype, cvalue in consts:
        namespace[cname] = cvalue
    return type(name, (Message,), namespace)


# --------------------------------------------------------------------------------------- conversion

def _to_store_value(f: Field, value: Any) -> Any:
    if f.kind == Nodetype.BASE:
        if f.base == 'string':
            if not isinstance(value, str):
                raise TypeError(f'field {f.name!r} expects str, got {type(value).__name__}')
            return value
        if f.base == 'bool':
            return bool(value)
        if f.base == 'byte':
            value = int(value)
            if not 0 <= value <= 255:
                raise ValueError(f'field {f.name!r} (byte) must be in [0, 255], got {value}')
            return value - 256 if value > 127 else value  # rosbags packs byte as int8
        return float(value) if f.base.startswith('float') else int(value)
    if f.kind == Nodetype.NAME:
        return to_store(value)
    if f.ref is not None:
        items = [to_store(v) for v in value]
    elif f.base == 'string':
        items = [str(v) for v in value]
    else:
        dtype = _NUMPY_DTYPE[f.base]
        items = np.ascontiguousarray(np.asarray(value, dtype=dtype)).reshape(-1)
    if f.kind == Nodetype.ARRAY and len(items) != f.length:
        raise ValueError(f'field {f.name!r} needs exactly {f.length} elements, got {len(items)}')
    if f.kind == Nodetype.SEQUENCE and f.bound and len(items) > f.bound:
        raise ValueError(f'field {f.name!r} holds at most {f.bound} elements, got {len(items)}')
    return items


def to_store(msg: Message) -> object:
    """Convert an rclpy-style message to the rosbags object its serializer expects."""
    cls = typestore().types[msg._type]
    kwargs = {}
    for f in msg._fields:
        try:
            kwargs[f.name] = _to_store_value(f, getattr(msg, f.name))
        except (TypeError, ValueError) as exc:
            raise type(exc)(f'{msg._type}.{f.name}: {exc}') from None
    if msg._has_empty_member:  # type: ignore[attr-defined]
        kwargs[EMPTY_MEMBER] = 0
    return cls(**kwargs)


def _from_store_value(f: Field, value: Any) -> Any:
    if f.kind == Nodetype.BASE:
        return value & 0xFF if f.base == 'byte' else value
    if f.kind == Nodetype.NAME:
        return from_store(value)
    if f.ref is not None:
        return [from_store(v) for v in value]
    if f.base == 'string':
        return list(value)
    if f.kind == Nodetype.ARRAY:
        return np.array(value, dtype=_NUMPY_DTYPE[f.base])  # a writable copy, not a view into the buffer
    if f.base == 'bool':
        return [bool(v) for v in value]
    out = array.array(_ARRAY_TYPECODE[f.base])
    out.frombytes(np.ascontiguousarray(value, dtype=_NUMPY_DTYPE[f.base]).tobytes())
    return out


def from_store(obj: Any) -> Message:
    """Convert a rosbags message object to the rclpy-style class."""
    cls = message_class(obj.__msgtype__)
    msg = cls.__new__(cls)
    for f in cls._fields:
        object.__setattr__(msg, f.name, _from_store_value(f, getattr(obj, f.name)))
    return msg


def serialize(msg: Message) -> bytes:
    """XCDR1 little-endian bytes with the 4-byte encapsulation header (rosbags' layout, no tail padding)."""
    return bytes(typestore().serialize_cdr(to_store(msg), msg._type, little_endian=True))


def deserialize(data: bytes | memoryview, ros_type: str) -> Message:
    """Decode CDR of either byte order (the header says which) into an rclpy-style message."""
    return from_store(typestore().deserialize_cdr(data, ros_type))


def type_of(msg_class: Any) -> str:
    """`pkg/msg/Name` of a message class generated here (what create_publisher/subscription accept)."""
    name = getattr(msg_class, '_type', None)
    if not isinstance(name, str) or name.count('/') != 2:
        raise TypeError(f'{msg_class!r} is not a message class of this runtime')
    return name
