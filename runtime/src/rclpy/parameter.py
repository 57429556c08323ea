"""rclpy.parameter: typed node parameters (`Parameter(name, value=...)`, `Parameter.Type`)."""

from __future__ import annotations

import array
from enum import Enum
from typing import Any, List, Optional

import numpy as np

AllowableParameterValue = Any
PARAMETER_SEPARATOR_STRING = '.'


class Parameter:
    """A named, typed value.  Its type is inferred from the value unless given."""

    class Type(Enum):
        NOT_SET = 0
        BOOL = 1
        INTEGER = 2
        DOUBLE = 3
        STRING = 4
        BYTE_ARRAY = 5
        BOOL_ARRAY = 6
        INTEGER_ARRAY = 7
        DOUBLE_ARRAY = 8
        STRING_ARRAY = 9

        @classmethod
        def from_parameter_value(cls, parameter_value: Any) -> 'Parameter.Type':
            """The type rclpy infers for a Python value; TypeError for anything else."""
            v = parameter_value
            if v is None:
                return cls.NOT_SET
            if isinstance(v, (bool, np.bool_)):
                return cls.BOOL
            if isinstance(v, (int, np.integer)):
                return cls.INTEGER
            if isinstance(v, (float, np.floating)):
                return cls.DOUBLE
            if isinstance(v, str):
                return cls.STRING
            if isinstance(v, (bytes, bytearray)):
                return cls.BYTE_ARRAY
            if isinstance(v, (list, tuple, array.array, np.ndarray)):
                items = list(v)
                if all(isinstance(i, bytes) for i in items):  # rclpy: an empty list is BYTE_ARRAY
                    return cls.BYTE_ARRAY
                if all(isinstance(i, (bool, np.bool_)) for i in items):
                    return cls.BOOL_ARRAY
                if all(isinstance(i, (int, np.integer)) and not isinstance(i, (bool, np.bool_))
                       for i in items):
                    return cls.INTEGER_ARRAY
                if all(isinstance(i, (float, np.floating)) for i in items):
                    return cls.DOUBLE_ARRAY
                if all(isinstance(i, str) for i in items):
                    return cls.STRING_ARRAY
                raise TypeError(
                    f'The given value is not a list of one of the allowed types {v!r}.')
            raise TypeError(f'The given value is not one of the allowed types {v!r}.')

        def check(self, parameter_value: Any) -> bool:
            if self == Parameter.Type.NOT_SET:
                return parameter_value is None
            try:
                inferred = Parameter.Type.from_parameter_value(parameter_value)
            except TypeError:
                return False
            if inferred == self:
                return True
            # an empty list fits every array type
            return (isinstance(parameter_value, (list, tuple)) and not parameter_value
                    and self.name.endswith('_ARRAY'))

    def __init__(self, name: str, type_: Optional['Parameter.Type'] = None,
                 value: AllowableParameterValue = None) -> None:
        if type_ is None:
            type_ = Parameter.Type.from_parameter_value(value)
        if not isinstance(type_, Parameter.Type):
            raise TypeError("type must be an instance of '{}'".format(repr(Parameter.Type)))
        if not type_.check(value):
            raise ValueError(f"Type '{type_}' and value '{value}' do not agree")
        self._type_ = type_
        self._name = name
        self._value = value

    @property
    def name(self) -> str:
        return self._name

    @property
    def type_(self) -> 'Parameter.Type':
        return self._type_

    @property
    def value(self) -> AllowableParameterValue:
        return self._value

    def __repr__(self) -> str:
        return f'Parameter(name={self._name!r}, type_={self._type_}, value={self._value!r})'

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Parameter):
            return NotImplemented
        return (self._name, self._type_) == (other._name, other._type_) and \
            np.array_equal(np.asarray(self._value, dtype=object), np.asarray(other._value, dtype=object))

    def get_parameter_value(self) -> Any:
        """This parameter as an rcl_interfaces/msg/ParameterValue."""
        from rcl_interfaces.msg import ParameterValue
        t = self._type_
        pv = ParameterValue(type=t.value)
        field = {
            Parameter.Type.BOOL: 'bool_value', Parameter.Type.INTEGER: 'integer_value',
            Parameter.Type.DOUBLE: 'double_value', Parameter.Type.STRING: 'string_value',
            Parameter.Type.BYTE_ARRAY: 'byte_array_value', Parameter.Type.BOOL_ARRAY: 'bool_array_value',
            Parameter.Type.INTEGER_ARRAY: 'integer_array_value',
            Parameter.Type.DOUBLE_ARRAY: 'double_array_value',
            Parameter.Type.STRING_ARRAY: 'string_array_value',
        }.get(t)
        if field is not None:
            value = self._value
            if t == Parameter.Type.BYTE_ARRAY:
                value = list(bytes(b''.join(value) if isinstance(value, list) else value))
            setattr(pv, field, value)
        return pv

    @classmethod
    def from_parameter_msg(cls, param_msg: Any) -> 'Parameter':
        return cls(param_msg.name, value=parameter_value_to_python(param_msg.value))

    def to_parameter_msg(self) -> Any:
        from rcl_interfaces.msg import Parameter as ParameterMsg
        return ParameterMsg(name=self._name, value=self.get_parameter_value())


def parameter_value_to_python(parameter_value: Any) -> AllowableParameterValue:
    """Python value of an rcl_interfaces/msg/ParameterValue."""
    t = Parameter.Type(parameter_value.type)
    if t == Parameter.Type.NOT_SET:
        return None
    field = {1: 'bool_value', 2: 'integer_value', 3: 'double_value', 4: 'string_value',
             5: 'byte_array_value', 6: 'bool_array_value', 7: 'integer_array_value',
             8: 'double_array_value', 9: 'string_array_value'}[t.value]
    value = getattr(parameter_value, field)
    if t in (Parameter.Type.INTEGER_ARRAY, Parameter.Type.DOUBLE_ARRAY, Parameter.Type.BOOL_ARRAY,
             Parameter.Type.STRING_ARRAY):
        return list(value)
    if t == Parameter.Type.BYTE_ARRAY:
        return [bytes([b]) for b in value]
    return value


def get_parameter_value(string_value: str) -> Any:
    """Parse a command-line style value (YAML) into an rcl_interfaces/msg/ParameterValue."""
    import yaml
    try:
        value = yaml.safe_load(string_value)
    except yaml.YAMLError:
        value = string_value
    if value is None:
        value = string_value
    try:
        return Parameter('x', value=value).get_parameter_value()
    except TypeError:
        return Parameter('x', value=string_value).get_parameter_value()


def parameter_dict_from_yaml_file(parameter_file: str, use_wildcard: bool = False,
                                  target_nodes: Optional[List[str]] = None,
                                  namespace: str = '') -> dict:
    """rclpy's helper: {name: rcl_interfaces/msg/Parameter} for the matching nodes of a params file."""
    from cage_ros_runtime.arguments import load_params_file, node_pattern_matches
    out = {}
    for pattern, params in load_params_file(parameter_file):
        if target_nodes is None and not use_wildcard:
            ok = True
        else:
            ok = any(node_pattern_matches(pattern, n) for n in (target_nodes or []))
            ok = ok or (use_wildcard and pattern in ('/**', '**'))
        if ok:
            for name, value in params.items():
                full = f'{namespace}{name}'
                out[full] = Parameter(full, value=value).to_parameter_msg()
    return out
