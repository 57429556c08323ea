"""Helpers for the runtime tests: unique DDS domains, node subprocesses, polling with deadlines."""

from __future__ import annotations

import itertools
import os
import subprocess
import threading
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
    """A node script (or command) in its own process, with line-wise stdout reading.

    A reader thread collects the output: select() on the pipe cannot see lines that the text wrapper has
    already buffered, so several lines arriving at once would otherwise stay unread.
    """

    def __init__(self, argv: list[str], env: dict[str, str]) -> None:
        self.proc = subprocess.Popen(argv, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                     text=True, bufsize=1)
        self.lines: list[str] = []
        self._changed = threading.Condition()
        self._eof = False
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        stream = self.proc.stdout
        try:
            for line in iter(stream.readline, ''):
                with self._changed:
                    self.lines.append(line)
                    self._changed.notify_all()
        except (ValueError, OSError):
            pass
        with self._changed:
            self._eof = True
            self._changed.notify_all()

    def read_until(self, text: str, timeout: float = 10.0) -> bool:
        deadline = time.monotonic() + timeout
        with self._changed:
            while not any(text in line for line in self.lines):
                remaining = deadline - time.monotonic()
                if remaining <= 0 or self._eof:
                    return False
                self._changed.wait(remaining)
        return True

    def finish(self, timeout: float = 10.0) -> int:
        self.proc.wait(timeout=timeout)
        self._reader.join(timeout)
        return self.proc.returncode

    @property
    def output(self) -> str:
        with self._changed:
            return ''.join(self.lines)

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        self._reader.join(5)


def spin_until(executor: object, predicate: Callable[[], bool], timeout: float) -> bool:
    """Spin `executor` until `predicate()` holds; False at the deadline."""
    deadline = time.monotonic() + timeout
    while not predicate():
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            return False
        executor.spin_once(timeout_sec=min(remaining, 0.1))
    return True
