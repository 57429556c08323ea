"""`ros2` for the world without ROS 2: run, topic list/info/echo/hz/pub, node list/info, param
list/get/set/dump, service list/type/call, action list/info/send_goal, interface list/show.

Output mirrors ros2cli closely enough for muscle memory and scripts (YAML messages separated by `---`,
`average rate:` blocks, one name per line).  Without a ros2 daemon every command waits for discovery:
`--spin-time` (default 1 s for lists) bounds that wait.  Tools create a hidden node `_ros2cli_<pid>`
(hidden from `node list` unless `-a`), as ros2cli does.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from typing import Any, Optional, Sequence


# ---------------------------------------------------------------------------------------- helpers

def _normalize_type(text: str) -> str:
    parts = text.strip().split('/')
    if len(parts) == 2:
        return f'{parts[0]}/msg/{parts[1]}'
    if len(parts) == 3:
        return text.strip()
    raise SystemExit(f'The passed message type is invalid: {text}')


def _add_qos_args(p: argparse.ArgumentParser) -> None:
    p.add_argument('--qos-profile', choices=['unknown', 'default', 'system_default', 'sensor_data',
                                             'services_default', 'parameters', 'parameter_events',
                                             'action_status_default', 'best_available'])
    p.add_argument('--qos-depth', type=int)
    p.add_argument('--qos-history', choices=['system_default', 'keep_last', 'keep_all'])
    p.add_argument('--qos-reliability', choices=['system_default', 'reliable', 'best_effort',
                                                 'best_available'])
    p.add_argument('--qos-durability', choices=['system_default', 'transient_local', 'volatile',
                                                'best_available'])


def _qos_from_args(args: argparse.Namespace, offered: Sequence[Any] = ()) -> Any:
    """A QoSProfile from `--qos-*`; unspecified policies adapt to the discovered publishers like
    ros2cli: reliable / transient local only if every publisher offers it."""
    from cyclonedds.qos import Policy
    from rclpy.qos import (DurabilityPolicy, HistoryPolicy, QoSPresetProfiles, QoSProfile,
                           ReliabilityPolicy)
    if args.qos_profile:
        base = QoSPresetProfiles.get_from_short_key(args.qos_profile)
        profile = QoSProfile(history=base.history, depth=base.depth, reliability=base.reliability,
                             durability=base.durability)
    else:
        profile = QoSProfile(depth=10)
        if offered:
            all_reliable = all(q[Policy.Reliability] is not None and
                               isinstance(q[Policy.Reliability], Policy.Reliability.Reliable)
                               for q in offered)
            all_tl = all(q[Policy.Durability] is not None and
                         q[Policy.Durability] == Policy.Durability.TransientLocal for q in offered)
            profile.reliability = ReliabilityPolicy.RELIABLE if all_reliable \
                else ReliabilityPolicy.BEST_EFFORT
            profile.durability = DurabilityPolicy.TRANSIENT_LOCAL if all_tl \
                else DurabilityPolicy.VOLATILE
    if args.qos_history:
        profile.history = HistoryPolicy.get_from_short_key(args.qos_history)
    if args.qos_depth is not None:
        profile.depth = args.qos_depth
    if args.qos_reliability:
        profile.reliability = ReliabilityPolicy.get_from_short_key(args.qos_reliability)
    if args.qos_durability:
        profile.durability = DurabilityPolicy.get_from_short_key(args.qos_durability)
    return profile


class _Tool:
    """An initialized rclpy context with a hidden node, for the topic commands."""

    def __init__(self) -> None:
        import rclpy
        from rclpy.node import Node
        rclpy.init(args=[])
        self.rclpy = rclpy
        self.node = Node(f'_ros2cli_{os.getpid()}', start_parameter_services=False, enable_rosout=False)
        self._observer = self.node._observer()  # noqa: SLF001 - start discovering right away

    def observer(self) -> Any:
        return self._observer

    def close(self) -> None:
        try:
            self.node.destroy_node()
        finally:
            self.rclpy.try_shutdown()

    def wait_for_type(self, topic: str, seconds: float) -> tuple[Optional[str], list]:
        """The topic's type and the QoS of its publishers, once discovered (None if not in time)."""
        deadline = time.monotonic() + seconds
        while True:
            eps = [e for e in self.observer().endpoints() if e.topic == topic]
            pubs = [e for e in eps if e.kind == 'publisher']
            chosen = pubs or eps
            if chosen:
                return chosen[0].ros_type, [e.qos for e in pubs]
            if time.monotonic() >= deadline:
                return None, []
            time.sleep(0.05)


def _spin_until(tool: _Tool, stop: Any, timeout: Optional[float] = None) -> bool:
    """Spin the tool node until `stop()` or timeout; False on timeout.  Ctrl-C ends quietly."""
    from rclpy.executors import ExternalShutdownException
    deadline = None if timeout is None else time.monotonic() + timeout
    try:
        while tool.rclpy.ok() and not stop():
            remaining = None if deadline is None else deadline - time.monotonic()
            if remaining is not None and remaining <= 0:
                return False
            tool.rclpy.spin_once(tool.node, timeout_sec=0.1 if remaining is None else min(remaining, 0.1))
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    return True


# ---------------------------------------------------------------------------------------- commands

def cmd_run(args: argparse.Namespace) -> int:
    """Run an executable of a package: a console_scripts entry point of the distribution named like the
    package (pip-installed ament_python packages), else `<prefix>/lib/<pkg>/<exe>`."""
    from importlib import metadata
    pkg, exe, rest = args.package_name, args.executable_name, list(args.argv)
    norm = pkg.replace('-', '_').lower()
    for ep in metadata.entry_points(group='console_scripts'):
        dist = getattr(ep, 'dist', None)
        dist_name = (dist.metadata['Name'] if dist is not None else '') or ''
        if ep.name == exe and dist_name.replace('-', '_').lower() == norm:
            sys.argv = [exe, *rest]
            func = ep.load()
            result = func()
            return result if isinstance(result, int) else 0
    prefixes = [p for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p]
    prefixes.append(sys.prefix)
    for prefix in prefixes:
        path = os.path.join(prefix, 'lib', pkg, exe)
        if os.path.isfile(path) and os.access(path, os.X_OK):
            os.execv(path, [path, *rest])
    try:
        metadata.distribution(pkg)
    except metadata.PackageNotFoundError:
        print('Package not found', file=sys.stderr)
        return 1
    print('No executable found', file=sys.stderr)
    return 1


def cmd_topic_list(args: argparse.Namespace) -> int:
    tool = _Tool()
    try:
        time.sleep(args.spin_time)
        topics = tool.observer().topics()
    finally:
        tool.close()
    for name in sorted(topics):
        if args.show_types:
            print(f'{name} [{", ".join(sorted(topics[name]))}]')
        else:
            print(name)
    return 0


def cmd_topic_echo(args: argparse.Namespace) -> int:
    from cage_ros_runtime.messages import message_class
    from cage_ros_runtime.yaml_format import message_to_yaml
    tool = _Tool()
    try:
        ros_type, offered = tool.wait_for_type(args.topic_name, args.spin_time)
        if args.message_type:
            ros_type = _normalize_type(args.message_type)
        if ros_type is None:
            print('Could not determine the type for the passed topic', file=sys.stderr)
            return 1
        count = [0]

        def on_msg(msg: Any) -> None:
            if args.once and count[0]:
                return
            count[0] += 1
            text = message_to_yaml(msg, None if args.full_length else args.truncate_length,
                                   args.no_arr, args.no_str, args.flow_style)
            sys.stdout.write(text + '---\n')
            sys.stdout.flush()

        tool.node.create_subscription(message_class(ros_type), args.topic_name, on_msg,
                                      _qos_from_args(args, offered))
        done = _spin_until(tool, lambda: args.once and count[0] > 0, args.timeout)
        return 0 if done or count[0] else 1
    finally:
        tool.close()


def cmd_topic_hz(args: argparse.Namespace) -> int:
    from cage_ros_runtime.messages import message_class
    tool = _Tool()
    try:
        ros_type, offered = tool.wait_for_type(args.topic_name, args.spin_time)
        if ros_type is None:
            print(f'WARNING: topic [{args.topic_name}] does not appear to be published yet',
                  file=sys.stderr)
            return 1
        stamps: list[float] = []

        def on_msg(_data: bytes) -> None:
            stamps.append(time.monotonic())
            del stamps[:-(args.window + 1)]

        tool.node.create_subscription(message_class(ros_type), args.topic_name, on_msg,
                                      _qos_from_args(args, offered), raw=True)
        last_print = [time.monotonic()]

        def tick() -> bool:
            now = time.monotonic()
            if now - last_print[0] >= 1.0:
                last_print[0] = now
                if len(stamps) >= 2:
                    deltas = [b - a for a, b in zip(stamps, stamps[1:])]
                    mean = sum(deltas) / len(deltas)
                    std = math.sqrt(sum((d - mean) ** 2 for d in deltas) / len(deltas))
                    print(f'average rate: {1.0 / mean:.3f}\n\tmin: {min(deltas):.3f}s '
                          f'max: {max(deltas):.3f}s std dev: {std:.5f}s window: {len(deltas) + 1}',
                          flush=True)
                else:
                    print('no new messages', flush=True)
            return False

        _spin_until(tool, tick, args.duration)
        return 0
    finally:
        tool.close()


def cmd_topic_pub(args: argparse.Namespace) -> int:
    import yaml

    from cage_ros_runtime.messages import message_class
    from cage_ros_runtime.yaml_format import set_fields_from_yaml
    ros_type = _normalize_type(args.message_type)
    cls = message_class(ros_type)
    values = yaml.safe_load(args.values) if args.values else None
    tool = _Tool()
    try:
        pub = tool.node.create_publisher(cls, args.topic_name, _qos_from_args(args))
        times = 1 if args.once else args.times
        wait_n = args.wait_matching_subscriptions
        if wait_n is None:
            wait_n = 1 if times else 0
        deadline = time.monotonic() + args.spin_time
        while pub.get_subscription_count() < wait_n and time.monotonic() < deadline:
            time.sleep(0.02)
        print('publisher: beginning loop')
        period = 1.0 / args.rate if args.rate > 0 else 1.0
        sent = 0
        try:
            while tool.rclpy.ok() and (not times or sent < times):
                msg = set_fields_from_yaml(cls(), values)
                sent += 1
                print(f'publishing #{sent}: {msg!r}\n', flush=True)
                pub.publish(msg)
                if times and sent >= times:
                    break
                time.sleep(period)
            pub.wait_for_all_acked()
            if args.keep_alive:
                time.sleep(args.keep_alive)
        except KeyboardInterrupt:
            pass
        return 0
    finally:
        tool.close()


def cmd_node_list(args: argparse.Namespace) -> int:
    tool = _Tool()
    try:
        time.sleep(args.spin_time)
        nodes = tool.observer().nodes()
    finally:
        tool.close()
    names = sorted({(ns.rstrip('/') + '/' + name) for ns, name in nodes
                    if args.all or not name.startswith('_')})
    if args.count_nodes:
        print(len(names))
    else:
        for n in names:
            print(n)
    return 0


# ---------------------------------------------------------------------------------------- parser

class _OneLineParser(argparse.ArgumentParser):
    """Usage mistakes are one line (`ros2 param get: error: ...`), exit 2, like other CLI errors here."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f'{self.prog}: error: {message}\n')


def build_parser() -> argparse.ArgumentParser:
    parser = _OneLineParser(prog='ros2', description='ros2 for the cage runtime (no ROS 2 install)')
    sub = parser.add_subparsers(dest='command', required=True, parser_class=_OneLineParser)

    run = sub.add_parser('run', help='Run a package specific executable')
    run.add_argument('package_name')
    run.add_argument('executable_name')
    run.add_argument('argv', nargs=argparse.REMAINDER)
    run.set_defaults(func=cmd_run)

    topic = sub.add_parser('topic', help='Various topic related sub-commands')
    tsub = topic.add_subparsers(dest='verb', required=True)

    tl = tsub.add_parser('list', help='Output a list of available topics')
    tl.add_argument('-t', '--show-types', action='store_true')
    tl.add_argument('-a', '--include-hidden-topics', action='store_true')
    tl.add_argument('--spin-time', type=float, default=1.0)
    tl.add_argument('--no-daemon', action='store_true')
    tl.set_defaults(func=cmd_topic_list)


    te = tsub.add_parser('echo', help='Output messages from a topic')
    te.add_argument('topic_name')
    te.add_argument('message_type', nargs='?')
    _add_qos_args(te)
    te.add_argument('--once', action='store_true')
    te.add_argument('--timeout', type=float, help='give up after this many seconds (exit 1)')
    te.add_argument('--truncate-length', '-l', type=int, default=128)
    te.add_argument('--full-length', '-f', action='store_true')
    te.add_argument('--no-arr', action='store_true')
    te.add_argument('--no-str', action='store_true')
    te.add_argument('--flow-style', action='store_true')
    te.add_argument('--spin-time', type=float, default=2.0,
                    help='how long to wait for the topic to be discovered')
    te.add_argument('--no-daemon', action='store_true')
    te.set_defaults(func=cmd_topic_echo)

    th = tsub.add_parser('hz', help='Print the average publishing rate to screen')
    th.add_argument('topic_name')
    _add_qos_args(th)
    th.add_argument('--window', '-w', type=int, default=10000)
    th.add_argument('--spin-time', type=float, default=2.0)
    th.add_argument('--duration', type=float, help='stop after this many seconds (runtime extension)')
    th.add_argument('--no-daemon', action='store_true')
    th.set_defaults(func=cmd_topic_hz)

    tp = tsub.add_parser('pub', help='Publish a message to a topic')
    tp.add_argument('topic_name')
    tp.add_argument('message_type')
    tp.add_argument('values', nargs='?', default='{}')
    _add_qos_args(tp)
    tp.add_argument('-r', '--rate', type=float, default=1.0)
    tp.add_argument('-1', '--once', action='store_true')
    tp.add_argument('-t', '--times', type=int, default=0)
    tp.add_argument('-w', '--wait-matching-subscriptions', type=int)
    tp.add_argument('--keep-alive', type=float, default=0.0)
    tp.add_argument('--spin-time', type=float, default=2.0,
                    help='how long to wait for matching subscriptions')
    tp.set_defaults(func=cmd_topic_pub)

    node = sub.add_parser('node', help='Various node related sub-commands')
    nsub = node.add_subparsers(dest='verb', required=True)
    nl = nsub.add_parser('list', help='Output a list of available nodes')
    nl.add_argument('-a', '--all', action='store_true')
    nl.add_argument('-c', '--count-nodes', action='store_true')
    nl.add_argument('--spin-time', type=float, default=1.0)
    nl.add_argument('--no-daemon', action='store_true')
    nl.set_defaults(func=cmd_node_list)

    from cage_ros_runtime import cli_graph, cli_param
    cli_graph.add_parsers(sub, tsub, nsub)
    cli_param.add_parsers(sub)
    return parser


def interrupted(exc: Optional[BaseException]) -> bool:
    """Whether a Ctrl-C lies under ``exc``: one that lands while a module is imported can come out
    wrapped (Python 3.11 raises ``RuntimeError: Error calling __set_name__ ...`` from it when it hits
    a class body, as in cyclonedds' ``GuardCondition``), and it must end the command as quietly."""
    seen = 0
    while exc is not None and seen < 20:
        if isinstance(exc, KeyboardInterrupt):
            return True
        exc, seen = exc.__cause__ or exc.__context__, seen + 1
    return False


def main(argv: Optional[Sequence[str]] = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        return 0
    except BrokenPipeError:  # `ros2 ... | head`: the reader went away
        sys.stdout = open(os.devnull, 'w')  # noqa: SIM115 - silence the flush at exit
        return 0
    except Exception as exc:  # noqa: BLE001 - a CLI prints one line, never a traceback
        from rclpy.exceptions import NotInitializedException
        from rclpy.executors import ExternalShutdownException
        if isinstance(exc, (NotInitializedException, ExternalShutdownException)) or interrupted(exc):
            return 0  # SIGINT/SIGTERM shut the context down mid-command: a quiet end, as ros2cli
        print(f'ros2 {args.command}: error: {type(exc).__name__}: {exc}', file=sys.stderr)
        return 1


if __name__ == '__main__':
    sys.exit(main())
