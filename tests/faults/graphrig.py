"""The whole node graph as separate processes, with hooks to kill, pause and restart any node
mid-mission, for the fault suite and benchmarks/bench_faults.py (no pytest needed here)."""
from __future__ import annotations

import json
import os
import signal
import subprocess
from pathlib import Path

from cage_planner_msgs.msg import HeadingSetpoint, MissionEvent
from nav_msgs.msg import Odometry

from cage_sim.ros_convert import EVENT_OUTCOMES, odom_pose, stamp_ns

from graph_testlib import BIN, ROOT, Probe, Proc

CFG = ROOT / "ros2_ws/src"
PACKAGES = {"sim_node": "cage_sim", "vehicle_node": "cage_sim", "navigator_node": "cage_sim",
            "rrt_node": "cage_global_rrt", "policy_node": "cage_reactive_ddpg", "mission_client": "cage_sim"}
NODES = ("policy_node", "rrt_node", "navigator_node", "vehicle_node", "sim_node")


def graph_env(domain: int) -> dict[str, str]:
    env = os.environ.copy()
    env.update(ROS_DOMAIN_ID=str(domain), PYTHONUNBUFFERED="1", MPLBACKEND="Agg",
               PATH=f"{BIN}{os.pathsep}{env.get('PATH', '')}")
    return env


class GraphRig:
    def __init__(self, logdir: Path, domain: int, scenario: str = "full_cage", seed: int = 0,
                 time_scale: float = 20.0, lockstep: bool = True, timeout: float = 120.0, extra: tuple = ()):
        self.logdir, self.env = Path(logdir), graph_env(domain)
        self.logdir.mkdir(parents=True, exist_ok=True)
        shared = ["-r", "__ns:=/cage", "--params-file", str(CFG / "cage_sim/config/graph.yaml"),
                  "-p", f"scenario:={scenario}", "-p", f"seed:={seed}", "-p", f"time_scale:={float(time_scale)}",
                  "-p", f"lockstep:={str(lockstep).lower()}", *extra]
        rrt = ["--params-file", str(CFG / "cage_global_rrt/config/rrt.yaml")]
        self.args = {"policy_node": shared, "rrt_node": rrt + shared, "vehicle_node": shared, "sim_node": shared,
                     "navigator_node": shared + ["-r", "goal_pose:=/goal_pose", "-p",
                                                 f"planner_config:={CFG / 'cage_global_rrt/config/rrt.yaml'}"],
                     "mission_client": shared + ["-p", f"timeout:={float(timeout)}",
                                                 "-p", f"png:={self.logdir / 'track.png'}"]}
        self.procs: dict[str, Proc] = {}
        self.runs: dict[str, int] = {}
        self.probe = Probe(domain)
        self.odoms = self.probe.listen(Odometry, "/cage/odom")
        self.events = self.probe.listen(MissionEvent, "/cage/mission_event")
        self.setpoints = self.probe.listen(HeadingSetpoint, "/cage/heading_setpoint")

    # --- processes -------------------------------------------------------------------------
    def start(self, name: str) -> Proc:
        k = self.runs[name] = self.runs.get(name, -1) + 1
        argv = ["ros2", "run", PACKAGES[name], name, "--ros-args", *self.args[name]]
        self.procs[name] = Proc(argv, self.env, self.logdir / f"{name}-{k}.log")
        return self.procs[name]

    def start_all(self) -> None:
        for name in NODES:
            self.start(name)
        self.start("mission_client")

    def kill(self, name: str) -> None:
        p = self.procs[name].proc
        p.send_signal(signal.SIGKILL)
        p.wait()

    def pause(self, name: str) -> None:
        self.procs[name].proc.send_signal(signal.SIGSTOP)

    def resume(self, name: str) -> None:
        self.procs[name].proc.send_signal(signal.SIGCONT)

    def restart(self, name: str) -> Proc:
        self.kill(name)
        return self.start(name)

    def stop(self) -> None:
        for p in self.procs.values():
            if p.proc.poll() is None:
                try:
                    p.proc.send_signal(signal.SIGCONT)
                except ProcessLookupError:
                    pass
            try:
                p.stop()
            except subprocess.TimeoutExpired:   # Proc.stop has SIGKILLed it; note it for the log reader
                with open(p.log, "a") as fh:
                    fh.write("\n[graphrig] did not exit within 10 s of SIGINT: SIGKILL\n")
        self.probe.close()

    # --- observation -----------------------------------------------------------------------
    def sim_time(self) -> float:
        return stamp_ns(self.odoms[-1].header.stamp) / 1e9 if self.odoms else 0.0

    def pose(self) -> tuple[float, float, float]:
        return odom_pose(self.odoms[-1])

    def wait(self, predicate, timeout: float) -> bool:
        return self.probe.until(predicate, timeout)

    def idle(self, seconds: float) -> None:
        self.probe.until(lambda: False, seconds)

    def result(self) -> dict | None:
        """The mission client's RESULT line, once it has exited."""
        client = self.procs["mission_client"]
        if client.proc.poll() is None:
            return None
        for line in client.output.splitlines():
            if line.startswith("RESULT "):
                return json.loads(line[7:])
        return {"outcome": f"client exit {client.proc.returncode}"}

    def outcomes(self) -> list[str]:
        return [EVENT_OUTCOMES[e.event] for e in self.events if e.event in EVENT_OUTCOMES]

    def logs(self) -> str:
        return "\n".join(f"--- {p.log.name}\n{p.output}" for p in self.procs.values())

    def tracebacks(self) -> list[str]:
        return [f.name for f in self.logdir.glob("*.log") if "Traceback" in f.read_text()]

    def held_since(self, after_ns: int) -> float | None:
        """Sim time (s) from which the vehicle stayed put up to its last pose, if it moved after ``after_ns``."""
        poses = [(stamp_ns(o.header.stamp), odom_pose(o)) for o in self.odoms]
        if not poses:
            return None
        _, (xe, ye, _) = poses[-1]
        moving = [t for t, (x, y, _) in poses if abs(x - xe) > 1e-9 or abs(y - ye) > 1e-9]
        return max(moving + [after_ns]) / 1e9
