"""`ros2 node info`, `ros2 topic info -v`, `ros2 service list/type`, `ros2 action list/info`,
`ros2 interface list/show`: graph and interface introspection in ros2cli's output format.

Why here and not in cli.py: each verb family is a small module; cli.py only builds the parser.
"""

from __future__ import annotations

import argparse
from typing import Any

from cage_ros_runtime.cli_common import Tool, fail, hidden

_DURABILITY = {'Volatile': 'VOLATILE', 'TransientLocal': 'TRANSIENT_LOCAL', 'Transient': 'TRANSIENT',
               'Persistent': 'PERSISTENT'}
_INFINITE = 0x7FFFFFFFFFFFFFFF


def _duration(policy: Any, attr: str) -> str:
    ns = getattr(policy, attr, None) if policy is not None else None
    if ns is None or ns >= _INFINITE:
        return 'Infinite'
    return f'{ns} nanoseconds'


def qos_summary(qos: Any, remote: bool = True) -> dict[str, str]:
    """The QoS lines ros2cli prints for an endpoint, from a discovered Cyclone Qos."""
    from cyclonedds.qos import Policy

    def get(policy: Any) -> Any:
        try:
            return qos[policy]
        except (KeyError, TypeError):
            return None

    rel = get(Policy.Reliability)
    dur = get(Policy.Durability)
    hist = get(Policy.History)
    live = get(Policy.Liveliness)
    rel_name = 'BEST_EFFORT' if rel == Policy.Reliability.BestEffort else 'RELIABLE'
    if dur is None:
        dur_name = 'VOLATILE'
    else:
        dur_name = next((v for k, v in _DURABILITY.items() if dur == getattr(Policy.Durability, k, None)),
                        str(dur))
    # DDS discovery does not carry a remote endpoint's history: ros2cli prints UNKNOWN as well
    hist_text = 'UNKNOWN' if hist is None or remote else (
        f'KEEP_LAST ({hist.depth})' if isinstance(hist, Policy.History.KeepLast) else 'KEEP_ALL')
    live_name = 'MANUAL_BY_TOPIC' if isinstance(live, Policy.Liveliness.ManualByTopic) else 'AUTOMATIC'
    return {'Reliability': rel_name, 'History (Depth)': hist_text, 'Durability': dur_name,
            'Lifespan': _duration(get(Policy.Lifespan), 'lifespan'),
            'Deadline': _duration(get(Policy.Deadline), 'deadline'),
            'Liveliness': live_name,
            'Liveliness lease duration': _duration(live, 'lease_duration')}


def incompatibility(offered: dict[str, str], requested: dict[str, str]) -> str | None:
    """The first policy a reader requests that a writer does not offer (DDS request/offer rules)."""
    if requested['Reliability'] == 'RELIABLE' and offered['Reliability'] == 'BEST_EFFORT':
        return 'RELIABILITY'
    order = ['VOLATILE', 'TRANSIENT_LOCAL', 'TRANSIENT', 'PERSISTENT']
    if requested['Durability'] in order and offered['Durability'] in order and \
            order.index(requested['Durability']) > order.index(offered['Durability']):
        return 'DURABILITY'
    if requested['Liveliness'] == 'MANUAL_BY_TOPIC' and offered['Liveliness'] == 'AUTOMATIC':
        return 'LIVELINESS'
    if requested['Deadline'] != 'Infinite' and (offered['Deadline'] == 'Infinite' or
                                                 int(offered['Deadline'].split()[0]) >
                                                 int(requested['Deadline'].split()[0])):
        return 'DEADLINE'
    return None


def _gid_text(gid: bytes) -> str:
    return '.'.join(f'{b:02x}' for b in gid)


def cmd_topic_info(args: argparse.Namespace) -> int:
    with Tool(args.spin_time) as tool:
        own = tool.node._domain.gid  # noqa: SLF001
        eps = [e for e in tool.observer().endpoints() if e.topic == args.topic_name
               and e.participant != own]
        nodes = tool.observer().node_of_endpoints()
    if not eps:
        return fail(f"Unknown topic '{args.topic_name}'", 1)
    types = sorted({e.ros_type for e in eps})
    print(f'Type: {types[0] if len(types) == 1 else ", ".join(types)}')
    pubs = [e for e in eps if e.kind == 'publisher']
    subs = [e for e in eps if e.kind == 'subscription']
    for title, group, kind in (('Publisher', pubs, 'PUBLISHER'), ('Subscription', subs, 'SUBSCRIPTION')):
        if args.verbose:
            print()
        print(f'{title} count: {len(group)}')
        if not args.verbose:
            continue
        for e in group:
            ns, name = nodes.get(e.gid, ('_NODE_NAMESPACE_UNKNOWN_', '_NODE_NAME_UNKNOWN_'))
            print()
            print(f'Node name: {name}')
            print(f'Node namespace: {ns}')
            print(f'Topic type: {e.ros_type}')
            print(f'Topic type hash: {e.type_hash or "INVALID"}')
            print(f'Endpoint type: {kind}')
            print(f'GID: {_gid_text(e.gid)}')
            print('QoS profile:')
            for k, v in qos_summary(e.qos).items():
                print(f'  {k}: {v}')
    if args.verbose:
        for s in subs:
            for p in pubs:
                policy = incompatibility(qos_summary(p.qos), qos_summary(s.qos))
                if policy is not None:
                    sn = nodes.get(s.gid, ('', '?'))
                    pn = nodes.get(p.gid, ('', '?'))
                    print(f"\nWARNING: subscription of node '{_fq(*sn)}' requests incompatible QoS from the "
                          f"publisher of node '{_fq(*pn)}': no messages will be received from it. "
                          f'Last incompatible policy: {policy}')
    return 0


def _fq(ns: str, name: str) -> str:
    return (ns.rstrip('/') + '/' + name) if ns else name


def _node_endpoints(tool: Tool, fq_name: str) -> dict[str, list[tuple[str, str]]] | None:
    observer = tool.observer()
    nodes = observer.nodes()
    if not any(_fq(ns, n) == fq_name for ns, n in nodes):
        return None
    owner = observer.node_of_endpoints()
    mine = {g for g, nn in owner.items() if _fq(*nn) == fq_name}
    out: dict[str, set] = {k: set() for k in ('Subscribers', 'Publishers', 'Service Servers',
                                              'Service Clients', 'Action Servers', 'Action Clients')}
    for e in observer.endpoints():
        if e.gid in mine:
            out['Publishers' if e.kind == 'publisher' else 'Subscribers'].add((e.topic, e.ros_type))
    for e in observer.endpoints(services=True):
        if e.gid not in mine or not e.dds_topic.startswith('rq/'):
            continue
        key = 'Service Servers' if e.kind == 'subscription' else 'Service Clients'
        if e.topic.endswith('/_action/send_goal') and e.ros_type.endswith('_SendGoal'):
            key = 'Action Servers' if key == 'Service Servers' else 'Action Clients'
            out[key].add((e.topic[:-len('/_action/send_goal')], e.ros_type[:-len('_SendGoal')]))
        elif '/_action/' not in e.topic:
            out[key].add((e.topic, e.ros_type))
    return {k: sorted(v) for k, v in out.items()}


def cmd_node_info(args: argparse.Namespace) -> int:
    with Tool(args.spin_time) as tool:
        info = _node_endpoints(tool, args.node_name)
    if info is None:
        return fail(f'Unable to find node \'{args.node_name}\'', 1)
    print(args.node_name)
    for title, items in info.items():
        print(f'  {title}:')
        for name, ros_type in items:
            print(f'    {name}: {ros_type}')
    return 0


def _services(tool: Tool) -> dict[str, set[str]]:
    out: dict[str, set[str]] = {}
    for e in tool.observer().endpoints(services=True):
        out.setdefault(e.topic, set()).add(e.ros_type)
    return out


def cmd_service_list(args: argparse.Namespace) -> int:
    with Tool(args.spin_time) as tool:
        services = _services(tool)
    for name in sorted(services):
        if hidden(name) and not args.include_hidden_services:
            continue
        print(f'{name} [{", ".join(sorted(services[name]))}]' if args.show_types else name)
    return 0


def cmd_service_type(args: argparse.Namespace) -> int:
    with Tool(args.spin_time) as tool:
        types = _services(tool).get(args.service_name)
    if not types:
        return fail(f"Unknown service '{args.service_name}'", 1)
    for t in sorted(types):
        print(t)
    return 0


def actions(tool: Tool) -> dict[str, dict[str, Any]]:
    """{action: {'types': set, 'servers': set of node names, 'clients': set}} from send_goal services."""
    owner = tool.observer().node_of_endpoints()
    out: dict[str, dict[str, Any]] = {}
    for e in tool.observer().endpoints(services=True):
        if not (e.dds_topic.startswith('rq/') and e.topic.endswith('/_action/send_goal')
                and e.ros_type.endswith('_SendGoal')):
            continue
        entry = out.setdefault(e.topic[:-len('/_action/send_goal')],
                               {'types': set(), 'servers': set(), 'clients': set()})
        entry['types'].add(e.ros_type[:-len('_SendGoal')])
        node = owner.get(e.gid)
        if node is not None:
            entry['servers' if e.kind == 'subscription' else 'clients'].add(_fq(*node))
    return out


def cmd_action_list(args: argparse.Namespace) -> int:
    with Tool(args.spin_time) as tool:
        found = actions(tool)
    for name in sorted(found):
        print(f'{name} [{", ".join(sorted(found[name]["types"]))}]' if args.show_types else name)
    return 0


def cmd_action_info(args: argparse.Namespace) -> int:
    with Tool(args.spin_time) as tool:
        entry = actions(tool).get(args.action_name)
    if entry is None:
        return fail(f"Unknown action '{args.action_name}'", 1)
    print(f'Action: {args.action_name}')
    for title, key in (('Action clients', 'clients'), ('Action servers', 'servers')):
        print(f'{title}: {len(entry[key])}')
        for node in sorted(entry[key]):
            types = f' [{", ".join(sorted(entry["types"]))}]' if args.show_types else ''
            print(f'    {node}{types}')
    return 0


# ------------------------------------------------------------------------------------ interfaces

def _kind_names() -> dict[str, list[str]]:
    from cage_ros_runtime.msgpkg import names
    from cage_ros_runtime.typestore import packages
    out: dict[str, list[str]] = {'msg': [], 'srv': [], 'action': []}
    for pkg in sorted(packages()):
        for kind in out:
            out[kind].extend(f'{pkg}/{kind}/{n}' for n in names(pkg, kind))
    return out


def cmd_interface_list(args: argparse.Namespace) -> int:
    kinds = _kind_names()
    titles = {'msg': 'Messages', 'srv': 'Services', 'action': 'Actions'}
    selected = [k for k in kinds if getattr(args, f'only_{k}', False)] or list(kinds)
    for kind in selected:
        print(f'{titles[kind]}:')
        for name in sorted(kinds[kind]):
            print(f'    {name}')
    return 0


def _definition(ros_type: str) -> str:
    """Field lines of one type, as in its interface file (constants first)."""
    from rosbags.typesys.base import Nodetype

    from cage_ros_runtime.messages import EMPTY_MEMBER
    from cage_ros_runtime.typestore import field_defaults, typestore
    consts, fields = typestore().fielddefs[ros_type]
    defaults = field_defaults(ros_type)
    lines = [f'{ctype} {cname}={cvalue!r}' if isinstance(cvalue, str) else f'{ctype} {cname}={cvalue}'
             for cname, ctype, cvalue in consts]

    def spell(desc: tuple) -> str:
        kind, arg = desc
        if kind == Nodetype.BASE:
            base, bound = arg
            return f'{base}<={bound}' if base == 'string' and bound else base
        if kind == Nodetype.NAME:
            pkg, _, name = arg.split('/')
            return f'{pkg}/{name}'
        sub, n = arg
        if kind == Nodetype.ARRAY:
            return f'{spell(sub)}[{n}]'
        return f'{spell(sub)}[<={n}]' if n else f'{spell(sub)}[]'

    for name, desc in fields:
        if name == EMPTY_MEMBER:
            continue
        default = f' {defaults[name]}' if name in defaults else ''
        lines.append(f'{spell(desc)} {name}{default}')
    return '\n'.join(lines)


def cmd_interface_show(args: argparse.Namespace) -> int:
    from cage_ros_runtime.typestore import typestore
    parts = args.type.split('/')
    if len(parts) == 2:
        parts = [parts[0], 'msg', parts[1]]
    name = '/'.join(parts)
    if len(parts) != 3 or name not in typestore().fielddefs:
        return fail(f'Unknown interface \'{args.type}\'', 1)
    kind = parts[1]
    if kind == 'msg':
        sections = [name]
    elif kind == 'srv':
        sections = [f'{name}_Request', f'{name}_Response']
    else:
        sections = [f'{name}_Goal', f'{name}_Result', f'{name}_Feedback']
    print('\n---\n'.join(_definition(s) for s in sections))
    return 0


def add_parsers(sub: Any, topic_sub: Any, node_sub: Any) -> None:
    """Register the verbs of this module on the `ros2` parser."""
    ti = topic_sub.add_parser('info', help='Print information about a topic')
    ti.add_argument('topic_name')
    ti.add_argument('-v', '--verbose', action='store_true',
                    help='endpoints with node names, GIDs and QoS; warns about incompatible QoS')
    ti.add_argument('--spin-time', type=float, default=1.0)
    ti.add_argument('--no-daemon', action='store_true')
    ti.set_defaults(func=cmd_topic_info)

    ni = node_sub.add_parser('info', help='Output information about a node')
    ni.add_argument('node_name')
    ni.add_argument('--spin-time', type=float, default=1.0)
    ni.add_argument('--no-daemon', action='store_true')
    ni.set_defaults(func=cmd_node_info)

    service = sub.add_parser('service', help='Various service related sub-commands')
    ssub = service.add_subparsers(dest='verb', required=True)
    sl = ssub.add_parser('list', help='Output a list of available services')
    sl.add_argument('-t', '--show-types', action='store_true')
    sl.add_argument('--include-hidden-services', action='store_true')
    sl.add_argument('--spin-time', type=float, default=1.0)
    sl.add_argument('--no-daemon', action='store_true')
    sl.set_defaults(func=cmd_service_list)
    st = ssub.add_parser('type', help='Output a service\'s type')
    st.add_argument('service_name')
    st.add_argument('--spin-time', type=float, default=1.0)
    st.add_argument('--no-daemon', action='store_true')
    st.set_defaults(func=cmd_service_type)
    from cage_ros_runtime.cli_call import add_service_call_parser
    add_service_call_parser(ssub)

    action = sub.add_parser('action', help='Various action related sub-commands')
    asub = action.add_subparsers(dest='verb', required=True)
    al = asub.add_parser('list', help='Output a list of action names')
    al.add_argument('-t', '--show-types', action='store_true')
    al.add_argument('--spin-time', type=float, default=1.0)
    al.set_defaults(func=cmd_action_list)
    ai = asub.add_parser('info', help='Print information about an action')
    ai.add_argument('action_name')
    ai.add_argument('-t', '--show-types', action='store_true')
    ai.add_argument('--spin-time', type=float, default=1.0)
    ai.set_defaults(func=cmd_action_info)
    from cage_ros_runtime.cli_call import add_send_goal_parser
    add_send_goal_parser(asub)

    interface = sub.add_parser('interface', help='Show information about ROS interfaces')
    isub = interface.add_subparsers(dest='verb', required=True)
    il = isub.add_parser('list', help='List all interface types available')
    il.add_argument('-m', '--only-msgs', dest='only_msg', action='store_true')
    il.add_argument('-s', '--only-srvs', dest='only_srv', action='store_true')
    il.add_argument('-a', '--only-actions', dest='only_action', action='store_true')
    il.set_defaults(func=cmd_interface_list)
    ish = isub.add_parser('show', help='Output the interface definition')
    ish.add_argument('type')
    ish.set_defaults(func=cmd_interface_show)
