"""``rig``: rrt_node started with ``ros2 run`` (the shipped rrt.yaml plus the test's arguments) and a
probe node, on a DDS domain of their own; every node started is stopped at the end."""
from __future__ import annotations

import itertools
import os
import sys
from pathlib import Path as FsPath

import pytest

sys.path.insert(0, str(FsPath(__file__).resolve().parents[1] / "graph"))
from graph_testlib import BIN, ROOT, Probe, Proc  # noqa: E402

_ids = itertools.count()


@pytest.fixture
def rig(tmp_path):
    env = os.environ.copy()
    env["ROS_DOMAIN_ID"] = str((os.getpid() * 13 + next(_ids) * 19) % 90 + 10)
    env["PYTHONUNBUFFERED"] = "1"
    env["PATH"] = f"{BIN}{os.pathsep}{env.get('PATH', '')}"
    probe = Probe(int(env["ROS_DOMAIN_ID"]))
    procs: list[Proc] = []

    def launch(*ros_args: str) -> Proc:
        argv = ["ros2", "run", "cage_global_rrt", "rrt_node", "--ros-args", "-r", "__ns:=/cage", "--params-file",
                str(ROOT / "ros2_ws/src/cage_global_rrt/config/rrt.yaml"), *ros_args]
        procs.append(Proc(argv, env, tmp_path / f"rrt_node-{len(procs)}.log"))
        return procs[-1]

    yield probe, launch
    for p in procs:
        p.stop()
    probe.close()
