"""Fixtures for the node-graph tests: real node processes via `ros2 run`, and a probe node in the
test process, all on a DDS domain of their own."""
from __future__ import annotations

import itertools
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Callable, Iterator

import pytest

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(sys.executable).parent
_ids = itertools.count()


def wait_for(predicate: Callable[[], bool], timeout: float, spin: Callable[[], None] | None = None) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        spin() if spin else time.sleep(0.02)
    return predicate()


@pytest.fixture
def ros_env(tmp_path) -> dict[str, str]:
    env = os.environ.copy()
    env["ROS_DOMAIN_ID"] = str((os.getpid() * 11 + next(_ids) * 17) % 200 + 20)
    env["PYTHONUNBUFFERED"] = "1"
    env["MPLBACKEND"] = "Agg"
    env["PATH"] = f"{BIN}{os.pathsep}{env.get('PATH', '')}"
    return env


class Proc:
    def __init__(self, argv: list[str], env: dict[str, str], log: Path):
        self.log = log
        self.fh = open(log, "w")
        self.proc = subprocess.Popen(argv, env=env, stdout=self.fh, stderr=subprocess.STDOUT, cwd=ROOT)

    @property
    def output(self) -> str:
        self.fh.flush()
        return self.log.read_text()

    def stop(self, timeout: float = 10.0) -> int:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
        try:
            return self.proc.wait(timeout)
        finally:
            if self.proc.poll() is None:
                self.proc.kill()
                self.proc.wait()
            self.fh.close()


@pytest.fixture
def launch(ros_env, tmp_path) -> Iterator[Callable[..., Proc]]:
    """launch(pkg, exe, *ros_args): `ros2 run pkg exe --ros-args ...`; stopped (SIGINT) at teardown."""
    procs: list[Proc] = []

    def _launch(pkg: str, exe: str, *ros_args: str) -> Proc:
        argv = ["ros2", "run", pkg, exe] + (["--ros-args", *ros_args] if ros_args else [])
        p = Proc(argv, ros_env, tmp_path / f"{exe}-{len(procs)}.log")
        procs.append(p)
        return p

    yield _launch
    for p in procs:
        p.stop()


class Probe:
    """A node in the test process that publishes and records what it hears."""

    def __init__(self, domain: int):
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from rclpy.signals import SignalHandlerOptions
        self.ctx = Context()
        rclpy.init(args=[], context=self.ctx, domain_id=domain, signal_handler_options=SignalHandlerOptions.NO)
        self.node = Node("probe", context=self.ctx)
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)
        self.heard: dict[str, list] = {}

    def listen(self, msg_type, topic: str, qos=10) -> list:
        got = self.heard.setdefault(topic, [])
        self.node.create_subscription(msg_type, topic, got.append, qos)
        return got

    def spin(self) -> None:
        self.executor.spin_once(timeout_sec=0.05)

    def until(self, predicate: Callable[[], bool], timeout: float = 20.0) -> bool:
        return wait_for(predicate, timeout, self.spin)

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self.ctx.try_shutdown()


@pytest.fixture
def probe(ros_env) -> Iterator[Probe]:
    p = Probe(int(ros_env["ROS_DOMAIN_ID"]))
    yield p
    p.close()
