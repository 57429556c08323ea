"""Smaller rclpy surface: time, QoS presets, logging filters, helpers, package lookup, no shadowing."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.timeout(30)


def test_time_duration_and_clock() -> None:
    from rclpy.clock import Clock, ClockType
    from rclpy.duration import Duration
    from rclpy.time import Time
    t = Time(seconds=1, nanoseconds=500_000_000)
    assert t.nanoseconds == 1_500_000_000 and t.seconds_nanoseconds() == (1, 500_000_000)
    msg = t.to_msg()
    assert (msg.sec, msg.nanosec) == (1, 500_000_000)
    assert Time.from_msg(msg).nanoseconds == t.nanoseconds
    assert (t + Duration(seconds=0.5)).nanoseconds == 2_000_000_000
    assert (Time(seconds=3) - Time(seconds=1)) == Duration(seconds=2)
    assert Duration(seconds=1.5).to_msg().nanosec == 500_000_000
    now = Clock(clock_type=ClockType.ROS_TIME).now()
    assert now.clock_type == ClockType.ROS_TIME and now.nanoseconds > 1_600_000_000 * 10**9


def test_qos_profiles() -> None:
    from rclpy.qos import (DurabilityPolicy, HistoryPolicy, InvalidQoSProfileException, QoSPresetProfiles,
                           QoSProfile, ReliabilityPolicy, qos_profile_sensor_data)
    assert qos_profile_sensor_data.depth == 5
    assert qos_profile_sensor_data.reliability == ReliabilityPolicy.BEST_EFFORT
    p = QoSProfile(depth=3)
    assert (p.history, p.reliability, p.durability) == (HistoryPolicy.KEEP_LAST, ReliabilityPolicy.RELIABLE,
                                                        DurabilityPolicy.VOLATILE)
    with pytest.raises(InvalidQoSProfileException):
        QoSProfile()
    assert QoSPresetProfiles.get_from_short_key('sensor_data') == qos_profile_sensor_data
    assert QoSPresetProfiles.SENSOR_DATA.value == qos_profile_sensor_data
    assert ReliabilityPolicy.get_from_short_key('best_effort') == ReliabilityPolicy.BEST_EFFORT


def test_logging_filters(capsys) -> None:
    from rclpy.logging import get_logger
    log = get_logger('cage_test')
    assert log.info('shown')
    assert not log.debug('hidden')
    emitted = [log.warning('once', once=True) for _ in range(3)]
    assert emitted == [True, False, False]
    throttled = [log.error('t', throttle_duration_sec=60.0) for _ in range(3)]
    assert throttled == [True, False, False]
    err = capsys.readouterr().err
    assert '[INFO] [' in err and '] [cage_test]: shown' in err and 'hidden' not in err
    assert err.count('once') == 1


def test_remove_ros_args() -> None:
    from rclpy.utilities import remove_ros_args
    assert remove_ros_args(['prog', '--x', '--ros-args', '-p', 'a:=1', '--', 'rest']) == \
        ['prog', '--x', 'rest']


def test_package_share_directory(tmp_path, monkeypatch) -> None:
    from ament_index_python.packages import PackageNotFoundError, get_package_share_directory
    src = Path(__file__).resolve().parents[2] / 'ros2_ws' / 'src' / 'cage_planner_msgs'
    assert Path(get_package_share_directory('cage_planner_msgs')) == src
    (tmp_path / 'share' / 'cage_planner_msgs').mkdir(parents=True)
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(tmp_path))
    assert Path(get_package_share_directory('cage_planner_msgs')) == tmp_path / 'share' / 'cage_planner_msgs'
    with pytest.raises(PackageNotFoundError):
        get_package_share_directory('no_such_package_here')


def test_real_message_package_earlier_on_path_wins(tmp_path) -> None:
    fake = tmp_path / 'std_msgs' / 'msg'
    fake.mkdir(parents=True)
    (tmp_path / 'std_msgs' / '__init__.py').write_text('')
    (fake / '__init__.py').write_text('class String:\n    REAL_ROS = True\n')
    code = 'from std_msgs.msg import String; print(getattr(String, "REAL_ROS", False))'
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, check=True,
                         env={'PYTHONPATH': str(tmp_path), 'PATH': '/usr/bin:/bin'})
    assert out.stdout.strip() == 'True'


def test_msg_path_env_adds_packages(tmp_path) -> None:
    pkg = tmp_path / 'extra_msgs' / 'msg'
    pkg.mkdir(parents=True)
    (pkg / 'Ping.msg').write_text('uint8 LEVEL=3\nstring text\n')
    code = ('from cage_ros_runtime.messages import message_class, serialize\n'
            'Ping = message_class("extra_msgs/msg/Ping")\n'
            'print(Ping.LEVEL, serialize(Ping(text="a")).hex())')
    import os
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, check=True,
                         env=dict(os.environ, CAGE_MSG_PATH=str(tmp_path)))
    assert out.stdout.split() == ['3', '00010000020000006100']


def test_callback_groups_and_guard_conditions(context) -> None:
    """rclpy code that passes callback groups and triggers guard conditions runs unchanged."""
    import threading

    from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
    from rclpy.executors import MultiThreadedExecutor
    from rclpy.node import Node

    from runtime_testlib import spin_until
    node = Node('grouped', context=context)
    fired: list = []
    node.create_timer(0.01, lambda: fired.append('timer'), callback_group=ReentrantCallbackGroup())
    guard = node.create_guard_condition(lambda: fired.append('guard'),
                                        callback_group=MutuallyExclusiveCallbackGroup())
    executor = MultiThreadedExecutor(context=context)
    executor.add_node(node)
    threading.Thread(target=guard.trigger).start()
    assert spin_until(executor, lambda: 'guard' in fired and 'timer' in fired, 10)
    assert node.destroy_guard_condition(guard)
    node.destroy_node()
