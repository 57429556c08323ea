"""Fixtures for the node-graph tests, all on a DDS domain of their own."""
from __future__ import annotations

import itertools
import os
from typing import Callable, Iterator

import pytest

from graph_testlib import BIN, Probe, Proc

_ids = itertools.count()


@pytest.fixture
def ros_env(tmp_path) -> dict[str, str]:
    env = os.environ.copy()
    env["ROS_DOMAIN_ID"] = str((os.getpid() * 11 + next(_ids) * 17) % 90 + 10)  # ports clear of the ephemeral range
    env["PYTHONUNBUFFERED"] = "1"
    env["MPLBACKEND"] = "Agg"
    env["PATH"] = f"{BIN}{os.pathsep}{env.get('PATH', '')}"
    return env


@pytest.fixture
def launch(ros_env, tmp_path) -> Iterator[Callable[..., Proc]]:
    """launch(pkg, exe, *ros_args): `ros2 run pkg exe --ros-args -r __ns:=/cage ...` (the scripts' default
    namespace, unless the arguments name another); stopped (SIGINT) at teardown."""
    procs: list[Proc] = []

    def _launch(pkg: str, exe: str, *ros_args: str) -> Proc:
        ns = [] if any(a.startswith("__ns:=") for a in ros_args) else ["-r", "__ns:=/cage"]
        argv = ["ros2", "run", pkg, exe, "--ros-args", *ns, *ros_args]
        p = Proc(argv, ros_env, tmp_path / f"{exe}-{len(procs)}.log")
        procs.append(p)
        return p

    yield _launch
    for p in procs:
        p.stop()


@pytest.fixture
def probe(ros_env) -> Iterator[Probe]:
    p = Probe(int(ros_env["ROS_DOMAIN_ID"]))
    yield p
    p.close()
