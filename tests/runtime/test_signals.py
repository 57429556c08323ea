"""SIGINT and SIGTERM end a spinning node cleanly (exit code 0), as rclpy does."""

from __future__ import annotations

import signal
import time

import pytest

pytestmark = pytest.mark.timeout(30)


@pytest.mark.parametrize('signum', [signal.SIGINT, signal.SIGTERM])
def test_signal_ends_spin_cleanly(spawn, signum) -> None:
    p = spawn('talker.py')
    assert p.read_until('READY', 15.0), p.output
    time.sleep(0.2)  # let it spin (the behaviour under test is the exit, not this delay)
    p.proc.send_signal(signum)
    assert p.finish(10) == 0, p.output
    assert 'CLEAN EXIT' in p.output
    assert 'Traceback' not in p.output
