"""Helpers for the runtime tests: unique DDS domains, node subprocesses, polling with deadlines."""

from __future__ import annotations

import itertools
import os
import select
import subprocess
import time
from pathlib import Path
from typing import Callable

NODES = Path(__file__).parent / 'nodes'
_counter = itertools.count()


def unique_domain() -> int:
    """A domain id in 1..232 unique within this test run and unlikely to collide with parallel runs."""
    return (os.getpid() * 7 + next(_counter) * 13) % 232 + 1


def wait_until(predicate: Callable[[], bool], timeout: float, step: float = 0.02) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(step)
    return predicate()


class NodeProcess:
    """A node script (or command) in its own process, with line-wise stdout reading."""

    def __init__(self, argv: list[str], env: dict[str, str]) -> None:
        self.proc = subprocess.Popen(argv, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                     text=True, bufsize=1)
        self.lines: list[str] = []

    def read_until(self, text: str, timeout: float = 10.0) -> bool:
        deadline = time.monotonic() + timeout
        while not any(text in line for line in self.lines):
            remaining = deadline - time.monotonic()
            if remaining <= 0 or self.proc.stdout is None:
                return False
            ready, _, _ = select.select([self.proc.stdout], [], [], remaining)
            if ready:
                line = self.proc.stdout.readline()
                if not line:
                    return any(text in line for line in self.lines)
                self.lines.append(line)
        return True

    def finish(self, timeout: float = 10.0) -> int:
        out, _ = self.proc.communicate(timeout=timeout)
        self.lines.extend(out.splitlines(keepends=True))
        return self.proc.returncode

    @property
    def output(self) -> str:
        return ''.join(self.lines)

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.communicate()


def spin_until(executor: object, predicate: Callable[[], bool], timeout: float) -> bool:
    """Spin `executor` until `predicate()` holds; False at the deadline."""
    deadline = time.monotonic() + timeout
    while not predicate():
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            return False
        executor.spin_once(timeout_sec=min(remaining, 0.1))
    return True
