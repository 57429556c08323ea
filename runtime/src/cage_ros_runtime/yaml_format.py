"""Messages as YAML the way `ros2 topic echo` prints them (ros2cli's message_to_yaml)."""

from __future__ import annotations

import array
import sys
from typing import Any

import numpy as np
import yaml

from cage_ros_runtime.messages import Message


def to_plain(value: Any, truncate_length: int | None = 128, no_arr: bool = False,
             no_str: bool = False) -> Any:
    """Messages -> dicts in field order; arrays -> lists (truncated with '...' like ros2cli)."""
    if isinstance(value, Message):
        return {f.name: to_plain(getattr(value, f.name), truncate_length, no_arr, no_str)
                for f in value._fields}
    if isinstance(value, (np.ndarray, array.array, list, tuple)):
        if no_arr:
            return f'<array type: {type(value).__name__}, length: {len(value)}>'
        items = list(value.tolist() if isinstance(value, np.ndarray) else value)
        if truncate_length is not None and len(items) > truncate_length:
            items = items[:truncate_length] + ['...']
        return [to_plain(v, truncate_length, no_arr, no_str) for v in items]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, str):
        if no_str:
            return f'<string length: <{len(value)}>>'
        if truncate_length is not None and len(value) > truncate_length:
            return value[:truncate_length] + '...'
    return value


class _Dumper(yaml.SafeDumper):
    pass


def message_to_yaml(msg: Message, truncate_length: int | None = 128, no_arr: bool = False,
                    no_str: bool = False, flow_style: bool = False) -> str:
    return yaml.dump(to_plain(msg, truncate_length, no_arr, no_str), Dumper=_Dumper,
                     sort_keys=False, allow_unicode=True, width=sys.maxsize,
                     default_flow_style=flow_style)


def set_fields_from_yaml(msg: Message, values: Any) -> Message:
    """Fill `msg` from a (YAML-parsed) mapping, recursively, as `ros2 topic pub` does."""
    if values is None:
        return msg
    if not isinstance(values, dict):
        raise ValueError(f'expected a mapping of field values, got {values!r}')
    from cage_ros_runtime.messages import message_class
    for name, value in values.items():
        field = next((f for f in msg._fields if f.name == name), None)
        if field is None:
            raise ValueError(f'{msg._type} has no field {name!r}')
        current = getattr(msg, name)
        if isinstance(current, Message):
            set_fields_from_yaml(current, value)
        elif field.ref is not None and isinstance(value, list):
            setattr(msg, name, [set_fields_from_yaml(message_class(field.ref)(), v) for v in value])
        else:
            setattr(msg, name, value)
    return msg
