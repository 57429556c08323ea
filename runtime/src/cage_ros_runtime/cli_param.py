"""`ros2 param list/get/set/dump` through a node's parameter services (rcl_interfaces/srv/*)."""

from __future__ import annotations

import argparse
import time
from typing import Any

import yaml

from cage_ros_runtime.cli_common import Tool, fail, hidden

_TIMEOUT = 10.0


def _require_node(tool: Tool, node_name: str, wait: float = 2.0) -> None:
    """ros2cli checks the graph first: an unknown node is 'Node not found' at once, not after a timeout."""
    deadline = time.monotonic() + wait
    while node_name not in _node_names(tool):
        if time.monotonic() >= deadline:
            raise LookupError(f'Node not found: {node_name}')
        time.sleep(0.05)


def _call(tool: Tool, executor: Any, srv_type: Any, node_name: str, service: str, request: Any) -> Any:
    _require_node(tool, node_name)
    client = tool.node.create_client(srv_type, f'{node_name}/{service}')
    if not client.wait_for_service(timeout_sec=_TIMEOUT):
        raise LookupError(f'Node not found: {node_name}')
    future = client.call_async(request)
    if not tool.spin_until(executor, future.done, _TIMEOUT):
        raise LookupError(f'no answer from {node_name}/{service} within {_TIMEOUT} s')
    return future.result()


def _node_names(tool: Tool) -> list[str]:
    return sorted({(ns.rstrip('/') + '/' + n) for ns, n in tool.observer().nodes()})


def _absolute(name: str) -> str:
    return name if name.startswith('/') else '/' + name


def _list(tool: Tool, executor: Any, node: str, prefixes: list[str]) -> list[str]:
    from rcl_interfaces.srv import ListParameters
    result = _call(tool, executor, ListParameters, node, 'list_parameters',
                   ListParameters.Request(prefixes=prefixes)).result
    return sorted(result.names)


def _values(tool: Tool, executor: Any, node: str, names: list[str]) -> list[Any]:
    from rcl_interfaces.srv import GetParameters
    return list(_call(tool, executor, GetParameters, node, 'get_parameters',
                      GetParameters.Request(names=names)).values)


def _python(value: Any) -> Any:
    """Plain Python (lists, not array.array / numpy) of a ParameterValue, for YAML and printing."""
    import array
    from rclpy.parameter import parameter_value_to_python
    out = parameter_value_to_python(value)
    if hasattr(out, 'tolist'):
        out = out.tolist()
    if isinstance(out, (tuple, array.array)):
        out = list(out)
    if isinstance(out, list):
        out = [v.tolist() if hasattr(v, 'tolist') else v for v in out]
    return out


def _describe_value(value: Any) -> str:
    """ros2cli's wording: `Double value is: 2.5`, `String values are: ['a']`, `Parameter not set.`."""
    from rcl_interfaces.msg import ParameterType as T
    scalar = {T.PARAMETER_BOOL: ('Boolean', 'bool_value'), T.PARAMETER_INTEGER: ('Integer', 'integer_value'),
              T.PARAMETER_DOUBLE: ('Double', 'double_value'), T.PARAMETER_STRING: ('String', 'string_value')}
    arrays = {T.PARAMETER_BYTE_ARRAY: ('Byte', 'byte_array_value'),
              T.PARAMETER_BOOL_ARRAY: ('Boolean', 'bool_array_value'),
              T.PARAMETER_INTEGER_ARRAY: ('Integer', 'integer_array_value'),
              T.PARAMETER_DOUBLE_ARRAY: ('Double', 'double_array_value'),
              T.PARAMETER_STRING_ARRAY: ('String', 'string_array_value')}
    if value.type in scalar:
        label, attr = scalar[value.type]
        return f'{label} value is: {getattr(value, attr)}'
    if value.type in arrays:
        label, attr = arrays[value.type]
        return f'{label} values are: {list(getattr(value, attr))}'
    return 'Parameter not set.'


def cmd_param_list(args: argparse.Namespace) -> int:
    with Tool(args.spin_time) as tool:
        executor = tool.executor()
        nodes = [_absolute(args.node_name)] if args.node_name else \
            [n for n in _node_names(tool) if not hidden(n)]
        for node in nodes:
            try:
                names = _list(tool, executor, node, [args.param_prefixes] if args.param_prefixes else [])
            except LookupError as exc:
                if args.node_name:
                    return fail(str(exc), 1)
                continue  # a node without parameter services
            if not args.node_name:
                print(f'{node}:')
            for name in names:
                print(f'  {name}')
    return 0


def cmd_param_get(args: argparse.Namespace) -> int:
    node = _absolute(args.node_name)
    with Tool(args.spin_time) as tool:
        try:
            value = _values(tool, tool.executor(), node, [args.parameter_name])[0]
        except LookupError as exc:
            return fail(str(exc), 1)
    from rcl_interfaces.msg import ParameterType
    if value.type == ParameterType.PARAMETER_NOT_SET:
        return fail('Parameter not set.', 1)
    print(_python(value) if args.hide_type else _describe_value(value))
    return 0


def _parse_value(text: str) -> Any:
    """A value as `ros2 param set` reads it (YAML scalar or list; otherwise the string itself)."""
    try:
        value = yaml.safe_load(text)
    except yaml.YAMLError:
        return text
    return text if value is None or isinstance(value, dict) else value


def cmd_param_set(args: argparse.Namespace) -> int:
    from rcl_interfaces.msg import Parameter as ParameterMsg
    from rcl_interfaces.srv import SetParameters
    from rclpy.parameter import Parameter
    node = _absolute(args.node_name)
    try:
        param = Parameter(args.parameter_name, value=_parse_value(args.value))
    except (TypeError, ValueError) as exc:
        return fail(f'Invalid value for {args.parameter_name}: {exc}', 2)
    with Tool(args.spin_time) as tool:
        try:
            response = _call(tool, tool.executor(), SetParameters, node, 'set_parameters',
                             SetParameters.Request(parameters=[ParameterMsg(
                                 name=param.name, value=param.get_parameter_value())]))
        except LookupError as exc:
            return fail(str(exc), 1)
    result = response.results[0]
    if result.successful:
        print('Set parameter successful')
        return 0
    return fail('Setting parameter failed' + (f': {result.reason}' if result.reason else ''), 1)


def _nested(flat: dict[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for name, value in sorted(flat.items()):
        here = out
        parts = name.split('.')
        for part in parts[:-1]:
            here = here.setdefault(part, {})
        here[parts[-1]] = value
    return out


def dump_yaml(node: str, values: dict[str, Any]) -> str:
    """The params-file YAML ros2cli's `param dump` writes (loadable with --params-file)."""
    return yaml.safe_dump({node: {'ros__parameters': _nested(values)}}, default_flow_style=False,
                          sort_keys=True)


def cmd_param_dump(args: argparse.Namespace) -> int:
    from rcl_interfaces.msg import ParameterType
    node = _absolute(args.node_name)
    with Tool(args.spin_time) as tool:
        executor = tool.executor()
        try:
            names = _list(tool, executor, node, [])
            values = _values(tool, executor, node, names)
        except LookupError as exc:
            return fail(str(exc), 1)
    flat = {n: _python(v) for n, v in zip(names, values) if v.type != ParameterType.PARAMETER_NOT_SET}
    text = dump_yaml(node, flat)
    if args.output_dir:
        import os
        path = os.path.join(args.output_dir, node.lstrip('/').replace('/', '__') + '.yaml')
        try:
            with open(path, 'w', encoding='utf-8') as f:
                f.write(text)
        except OSError as exc:
            return fail(f'cannot write {path}: {exc.strerror}', 1)
        print(f'Saved parameters of {node} to {path}')
    else:
        print(text, end='')
    return 0


def add_parsers(sub: Any) -> None:
    param = sub.add_parser('param', help='Various param related sub-commands')
    psub = param.add_subparsers(dest='verb', required=True)

    def common(p: Any, node_optional: bool = False) -> None:
        if node_optional:
            p.add_argument('node_name', nargs='?')
        else:
            p.add_argument('node_name')
        p.add_argument('--spin-time', type=float, default=0.5)
        p.add_argument('--no-daemon', action='store_true')
        p.add_argument('--include-hidden-nodes', action='store_true')

    pl = psub.add_parser('list', help='Output a list of available parameters')
    common(pl, node_optional=True)
    pl.add_argument('--param-prefixes', default='')
    pl.set_defaults(func=cmd_param_list)
    pg = psub.add_parser('get', help='Get parameter')
    common(pg)
    pg.add_argument('parameter_name')
    pg.add_argument('--hide-type', action='store_true')
    pg.set_defaults(func=cmd_param_get)
    ps = psub.add_parser('set', help='Set parameter')
    common(ps)
    ps.add_argument('parameter_name')
    ps.add_argument('value')
    ps.set_defaults(func=cmd_param_set)
    pd = psub.add_parser('dump', help='Show all of the parameters of a node in a YAML file format')
    common(pd)
    pd.add_argument('--output-dir', default='')
    pd.set_defaults(func=cmd_param_dump)
