"""Fixtures for the runtime tests (helpers live in runtime_testlib)."""

from __future__ import annotations

import os
import sys
from typing import Callable, Iterator

import pytest


def _runtime_in_use() -> bool:
    try:
        import rclpy
    except ImportError:
        return False
    return "cage_ros_runtime" in getattr(rclpy, "__doc__", "") or "/runtime/src/" in (rclpy.__file__ or "")


# These tests exercise the project's no-ROS runtime; on a machine with real ROS 2 (docker/) there is
# nothing of it to test, and loading the cyclonedds wheel beside rmw's own Cyclone would be wrong.
collect_ignore_glob = [] if _runtime_in_use() else ["test_*.py"]

from runtime_testlib import NODES, NodeProcess, unique_domain


@pytest.fixture
def ros_env() -> dict[str, str]:
    env = os.environ.copy()
    env['ROS_DOMAIN_ID'] = str(unique_domain())
    env['PYTHONUNBUFFERED'] = '1'
    return env


@pytest.fixture
def spawn(ros_env: dict[str, str]) -> Iterator[Callable[..., NodeProcess]]:
    """spawn('talker.py', '--ros-args', ...) or spawn(['ros2', ...], env=...): killed at teardown."""
    procs: list[NodeProcess] = []

    def _spawn(script: str | list[str], *args: str, env: dict[str, str] | None = None) -> NodeProcess:
        argv = [sys.executable, str(NODES / script), *args] if isinstance(script, str) else script
        p = NodeProcess(argv, env or ros_env)
        procs.append(p)
        return p

    yield _spawn
    for p in procs:
        p.kill()


@pytest.fixture
def context(ros_env: dict[str, str]) -> Iterator[object]:
    """An initialized rclpy Context in the test's domain (signal handlers left to pytest)."""
    import rclpy
    from rclpy.context import Context
    from rclpy.signals import SignalHandlerOptions
    ctx = Context()
    rclpy.init(args=[], context=ctx, domain_id=int(ros_env['ROS_DOMAIN_ID']),
               signal_handler_options=SignalHandlerOptions.NO)
    yield ctx
    ctx.try_shutdown()

