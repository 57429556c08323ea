"""Command-line ROS arguments (`--ros-args ... [--]`), params files and how they apply to a node.

Supported inside `--ros-args`: `-p/--param [node:]name:=value`, `--params-file FILE`,
`-r/--remap [node:]from:=to` (including `__node:=`, `__ns:=`), `--log-level [name:=]level`,
`-e/--enclave` (accepted, ignored); logging toggles such as `--disable-rosout-logs` are accepted and ignored.
Values given with `-p` are YAML, as rcl parses them.  Parameter rules apply in command-line order, so a
later `-p` overrides an earlier params file and vice versa.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any

import yaml

_IGNORED_FLAGS = {
    '--enable-rosout-logs', '--disable-rosout-logs', '--enable-stdout-logs', '--disable-stdout-logs',
    '--enable-external-lib-logs', '--disable-external-lib-logs',
}
_FLAGS_WITH_ARG_IGNORED = {'-e', '--enclave', '--log-config-file'}


class RosArgumentError(ValueError):
    """Malformed or unknown ROS argument (rcl refuses them too)."""


@dataclass
class RosArguments:
    """ROS arguments of a context (global) or of one node (`cli_args`)."""

    #: (node pattern or None, {param name: python value}) in command-line order.
    param_rules: list[tuple[str | None, dict[str, Any]]] = field(default_factory=list)
    #: (node name or None, from, to) in command-line order.
    remaps: list[tuple[str | None, str, str]] = field(default_factory=list)
    node_name: str | None = None
    namespace: str | None = None
    log_levels: list[tuple[str | None, str]] = field(default_factory=list)
    #: False after `--disable-rosout-logs`.
    rosout_enabled: bool = True

    def extend(self, other: 'RosArguments') -> 'RosArguments':
        return RosArguments(self.param_rules + other.param_rules, self.remaps + other.remaps,
                            other.node_name or self.node_name, other.namespace or self.namespace,
                            self.log_levels + other.log_levels,
                            self.rosout_enabled and other.rosout_enabled)


def _split_rule(text: str, flag: str) -> tuple[str | None, str, str]:
    if ':=' not in text:
        raise RosArgumentError(f"argument of '{flag}' must be of the form [node:]name:=value: {text!r}")
    lhs, value = text.split(':=', 1)
    node = None
    if ':' in lhs:
        node, lhs = lhs.split(':', 1)
    return node, lhs, value


def parse_value(text: str) -> Any:
    """A `-p` value as rcl reads it: YAML scalars and flow lists; anything else is a string."""
    try:
        value = yaml.safe_load(text)
    except yaml.YAMLError:
        return text
    if value is None or isinstance(value, dict):
        return text
    return value


def _check_value(value: Any, where: str) -> None:
    """A parameter value rcl can hold (scalars or a list of one type); rcl refuses the rest at init."""
    from rclpy.parameter import Parameter
    try:
        Parameter.Type.from_parameter_value(value)
    except TypeError:
        kind = 'a list mixing types' if isinstance(value, list) else type(value).__name__
        raise RosArgumentError(f'{where}: {kind} is not a parameter value ({value!r})') from None


def split_ros_args(args: list[str]) -> tuple[list[str], list[str]]:
    """(ROS arguments, the rest), honouring multiple `--ros-args` sections closed by `--`."""
    ros, rest = [], []
    inside = False
    for arg in args:
        if arg == '--ros-args':
            inside = True
        elif inside and arg == '--':
            inside = False
        elif inside:
            ros.append(arg)
        else:
            rest.append(arg)
    return ros, rest


def parse(args: list[str] | None) -> RosArguments:
    """Parse the ROS arguments found in a full argument list (program name included or not)."""
    ros, _ = split_ros_args(list(args or []))
    out = RosArguments()
    it = iter(ros)
    for arg in it:
        def value_of(flag: str) -> str:
            try:
                return next(it)
            except StopIteration:
                raise RosArgumentError(f"'{flag}' needs an argument") from None
        if arg in ('-p', '--param'):
            node, name, value = _split_rule(value_of(arg), arg)
            parsed = parse_value(value)
            _check_value(parsed, f"'{arg} {name}:={value}'")
            out.param_rules.append((node, {name: parsed}))
        elif arg == '--params-file':
            path = value_of(arg)
            for pattern, params in load_params_file(path):
                for name, parsed in params.items():
                    _check_value(parsed, f"--params-file {path!r}: parameter '{name}' of '{pattern}'")
                out.param_rules.append((pattern, params))
        elif arg in ('-r', '--remap'):
            node, src, dst = _split_rule(value_of(arg), arg)
            if src == '__node' or src == '__name':
                out.node_name = dst
            elif src == '__ns':
                out.namespace = dst
            else:
                out.remaps.append((node, src, dst))
        elif arg == '--log-level':
            text = value_of(arg)
            if ':=' in text:
                name, level = text.split(':=', 1)
                out.log_levels.append((name, level))
            else:
                out.log_levels.append((None, text))
        elif arg in _FLAGS_WITH_ARG_IGNORED:
            value_of(arg)
        elif arg == '--disable-rosout-logs':
            out.rosout_enabled = False
        elif arg in _IGNORED_FLAGS:
            pass
        else:
            raise RosArgumentError(f'unknown ROS argument {arg!r}')
    return out


def _flatten(prefix: str, value: Any, out: dict[str, Any]) -> None:
    if isinstance(value, dict):
        for k, v in value.items():
            _flatten(f'{prefix}.{k}' if prefix else str(k), v, out)
    else:
        out[prefix] = value


def load_params_file(path: str) -> list[tuple[str, dict[str, Any]]]:
    """[(node pattern, {dotted name: value})] from a ROS 2 params file.

    Node keys may be nested (`ns: node: ros__parameters:`) or written as one path (`/ns/node:`), and may
    use the `*`/`**` wildcards (`/**:`).
    """
    try:
        with open(path, encoding='utf-8') as f:
            doc = yaml.safe_load(f) or {}
    except FileNotFoundError:
        raise RosArgumentError(f'--params-file {path!r}: no such file') from None
    except OSError as exc:
        raise RosArgumentError(f'--params-file {path!r}: cannot be read ({exc.strerror})') from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, 'problem_mark', None)
        where = f' at line {mark.line + 1}, column {mark.column + 1}' if mark is not None else ''
        problem = getattr(exc, 'problem', None) or 'not valid YAML'
        raise RosArgumentError(f'--params-file {path!r}: {problem}{where}') from None
    if not isinstance(doc, dict):
        raise RosArgumentError(f'--params-file {path!r}: must hold a mapping of node names')
    out: list[tuple[str, dict[str, Any]]] = []

    def walk(path_parts: list[str], node: dict) -> None:
        for key, value in node.items():
            if key == 'ros__parameters':
                params: dict[str, Any] = {}
                _flatten('', value or {}, params)
                pattern = '/' + '/'.join(p.strip('/') for p in path_parts if p.strip('/'))
                out.append((pattern, params))
            elif isinstance(value, dict):
                walk(path_parts + [str(key)], value)
            else:
                where = '/'.join(path_parts + [str(key)])
                raise RosArgumentError(f"--params-file {path!r}: '{where}' is not a node mapping with "
                                       "'ros__parameters'")
    walk([], doc)
    if doc and not out:
        raise RosArgumentError(f"--params-file {path!r}: no 'ros__parameters' section")
    return out


def node_pattern_matches(pattern: str | None, fq_node_name: str) -> bool:
    """Does a params-file/`-p` node key match a fully qualified node name?

    `/**` matches every node, `*` one name token, `**` any number of tokens; a key without a leading
    slash is taken as absolute, as rcl does.
    """
    if pattern is None:
        return True
    if not pattern.startswith('/'):
        pattern = '/' + pattern
    regex = ''
    for token in pattern.strip('/').split('/'):
        if token == '**':
            regex += r'(/[^/]+)*'
        else:
            regex += '/' + re.escape(token).replace(r'\*', '[^/]*')
    return re.fullmatch(regex or '/', fq_node_name) is not None


def parameter_overrides(args: RosArguments, node_name: str, namespace: str) -> dict[str, Any]:
    """The parameter values the command line gives to one node, later rules winning."""
    fq = (namespace.rstrip('/') + '/' + node_name) if namespace != '/' else '/' + node_name
    out: dict[str, Any] = {}
    for pattern, params in args.param_rules:
        if pattern is not None and '/' not in pattern and '*' not in pattern:
            # `-p node:name:=v` names a node by its bare name
            if pattern != node_name:
                continue
        elif not node_pattern_matches(pattern, fq):
            continue
        out.update(params)
    return out
