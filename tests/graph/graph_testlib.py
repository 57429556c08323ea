"""Helpers for the node-graph tests: node processes via `ros2 run`, and a probe node in the test
process. (Named apart from conftest so test modules can import it unambiguously.)"""
from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Callable

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(sys.executable).parent


def wait_for(predicate: Callable[[], bool], timeout: float, spin: Callable[[], None] | None = None) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        spin() if spin else time.sleep(0.02)
    return predicate()


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
