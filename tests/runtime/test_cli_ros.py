"""The runtime's `ros2` against running nodes: param, service, action, node info, topic info -v,
interface; and bad input as one line (never a traceback).

The verbs run in this process (`cli.main`, the `ros2` entry point) against nodes in their own processes,
which saves a Python start per command; the error cases run the real `ros2` executable, to see its
exact stderr and exit status.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any, Callable

import yaml

from cage_ros_runtime.arguments import load_params_file

ROS2 = str(Path(sys.executable).with_name('ros2'))


def ros2(env: dict, *args: str, timeout: float = 60) -> subprocess.CompletedProcess:
    return subprocess.run([ROS2, *args], env=env, capture_output=True, text=True, timeout=timeout)


class InProcess:
    """`ros2 ...` through cli.main in this process, in the test's domain; returns a CompletedProcess."""

    def __init__(self, env: dict, capsys: Any, monkeypatch: Any) -> None:
        monkeypatch.setenv('ROS_DOMAIN_ID', env['ROS_DOMAIN_ID'])
        self.capsys = capsys

    def __call__(self, *args: str) -> subprocess.CompletedProcess:
        from cage_ros_runtime.cli import main
        self.capsys.readouterr()
        code = main(list(args))
        out, err = self.capsys.readouterr()
        return subprocess.CompletedProcess(list(args), code, out, err)


def one_line_error(result: subprocess.CompletedProcess) -> bool:
    return 'Traceback' not in result.stderr and len(result.stderr.strip().splitlines()) == 1


def test_param_list_get_set_dump(spawn: Callable[..., Any], ros_env: dict, tmp_path: Path, capsys: Any,
                                 monkeypatch: Any) -> None:
    node = spawn('param_node.py', '--ros-args', '-r', '__ns:=/cage')
    assert node.read_until('READY', 60), node.output
    ros2_ = InProcess(ros_env, capsys, monkeypatch)
    listed = ros2_('param', 'list', '/cage/param_node')
    assert listed.returncode == 0, listed.stderr
    assert {'speed', 'label', 'shield', 'gains', 'use_sim_time'} <= {line.strip() for line in listed.stdout.splitlines()}
    for name, expected in (('speed', 'Double value is: 1.0'), ('gains', 'Double values are: [0.5, 0.25]')):
        got = ros2_('param', 'get', '/cage/param_node', name)
        assert got.stdout.strip() == expected, (name, got.stdout, got.stderr)
    ok = ros2_('param', 'set', '/cage/param_node', 'shield', 'false')
    assert ok.returncode == 0 and ok.stdout.strip() == 'Set parameter successful'
    assert node.read_until('SET shield=False', 10)  # the node's parameter callback saw it
    refused = ros2_('param', 'set', '/cage/param_node', 'speed', '-2.0')
    assert refused.returncode == 1 and refused.stderr.strip() == \
        'Setting parameter failed: speed must not be negative'
    dumped = ros2_('param', 'dump', '/cage/param_node')
    doc = yaml.safe_load(dumped.stdout)
    assert doc['/cage/param_node']['ros__parameters']['shield'] is False
    assert doc['/cage/param_node']['ros__parameters']['gains'] == [0.5, 0.25]
    # the dump is a params file
    path = tmp_path / 'dump.yaml'
    path.write_text(dumped.stdout)
    assert load_params_file(str(path))[0][1]['label'] == 'cage'
    missing = ros2(ros_env, 'param', 'get', '/nobody', 'x', '--spin-time', '0')
    assert missing.returncode == 1 and one_line_error(missing)


def test_service_and_action_verbs(spawn: Callable[..., Any], ros_env: dict, capsys: Any,
                                  monkeypatch: Any) -> None:
    fib = spawn('fibonacci_server.py')
    srv = spawn('service_server.py')
    assert fib.read_until('READY', 60) and srv.read_until('READY', 60)
    ros2_ = InProcess(ros_env, capsys, monkeypatch)
    services = ros2_('service', 'list', '-t')
    assert '/set_flag [std_srvs/srv/SetBool]' in services.stdout.splitlines()
    assert not any('_action' in line for line in services.stdout.splitlines())
    call = ros2_('service', 'call', '/set_flag', 'std_srvs/srv/SetBool', '{data: true}')
    assert call.returncode == 0 and "message='was False'" in call.stdout
    assert ros2_('action', 'list', '-t').stdout.strip() == \
        '/fibonacci [example_interfaces/action/Fibonacci]'
    info = ros2_('action', 'info', '/fibonacci')
    assert 'Action servers: 1' in info.stdout and '/fibonacci_server' in info.stdout
    goal = ros2_('action', 'send_goal', '/fibonacci', 'example_interfaces/action/Fibonacci',
                '{order: 4}', '--feedback')
    assert goal.returncode == 0, goal.stderr
    assert 'Goal accepted with ID:' in goal.stdout and 'Feedback:' in goal.stdout
    assert goal.stdout.rstrip().endswith('Goal finished with status: SUCCEEDED')
    rejected = ros2_('action', 'send_goal', '/fibonacci', 'example_interfaces/action/Fibonacci',
                    '{order: -1}')
    assert rejected.returncode == 1 and 'Goal was rejected.' in rejected.stdout
    node_info = ros2_('node', 'info', '/fibonacci_server')
    lines = node_info.stdout.splitlines()
    assert '    /fibonacci: example_interfaces/action/Fibonacci' in \
        lines[lines.index('  Action Servers:'):]
    bad = ros2(ros_env, 'service', 'call', '/set_flag', 'std_srvs/srv/SetBool', '{data: [}')
    assert bad.returncode == 2 and one_line_error(bad)


def test_topic_info_verbose_warns_about_incompatible_qos(spawn: Callable[..., Any], ros_env: dict,
                                                        capsys: Any, monkeypatch: Any) -> None:
    ros2_ = InProcess(ros_env, capsys, monkeypatch)
    talker = spawn('talker.py', '--ros-args', '-p', 'reliable:=false')
    assert talker.read_until('READY', 60)
    echo = spawn([ROS2, 'topic', 'echo', '/chatter', '--qos-reliability', 'reliable', '--timeout', '30'])
    info = None
    for _ in range(10):
        info = ros2_('topic', 'info', '-v', '/chatter')
        if 'Subscription count: 1' in info.stdout:
            break
    assert info is not None and 'Node name: talker' in info.stdout, info.stdout
    assert 'Reliability: BEST_EFFORT' in info.stdout and 'Reliability: RELIABLE' in info.stdout
    assert 'Last incompatible policy: RELIABILITY' in info.stdout
    echo.kill()


def test_interfaces_and_usage_errors(ros_env: dict, capsys: Any, monkeypatch: Any) -> None:
    ros2_ = InProcess(ros_env, capsys, monkeypatch)
    listed = ros2_('interface', 'list')
    lines = [line.strip() for line in listed.stdout.splitlines()]
    assert {'geometry_msgs/msg/Pose', 'std_srvs/srv/SetBool', 'example_interfaces/action/Fibonacci',
            'rcl_interfaces/srv/GetParameters'} <= set(lines)
    shown = ros2_('interface', 'show', 'example_interfaces/action/Fibonacci')
    assert shown.stdout.split() == ['int32', 'order', '---', 'int32[]', 'sequence', '---', 'int32[]', 'sequence']
    assert 'float64 w 1.0' in ros2_('interface', 'show', 'geometry_msgs/msg/Quaternion').stdout
    for args in (('param',), ('interface', 'show', 'no_pkg/msg/Nope'), ('bogus',)):
        result = ros2(ros_env, *args)
        assert result.returncode in (1, 2) and one_line_error(result), (args, result.stderr)


def test_malformed_ros_args_are_one_line(spawn: Callable[..., Any], tmp_path: Path) -> None:
    broken = tmp_path / 'broken.yaml'
    broken.write_text('node:\n  ros__parameters: [1, 2\n')
    cases = [(('--ros-args', '-p', 'speed'), "'-p'"),
             (('--ros-args', '--params-file', str(tmp_path / 'missing.yaml')), 'no such file'),
             (('--ros-args', '--params-file', str(broken)), 'line')]
    for args, named in cases:
        p = spawn('param_node.py', *args)
        assert p.finish(20) == 2, (args, p.output)
        assert 'Traceback' not in p.output and len(p.output.strip().splitlines()) == 1, p.output
        assert named in p.output, p.output
