"""Fault table: every node of the graph killed, paused (SIGSTOP) or restarted mid-mission.

For each (mode, node, fault) a fresh graph flies the built-in full_cage mission (seed 0, time scale 20x);
at ``--at`` sim seconds the benchmark hits the node:
  kill     SIGKILL, never restarted (does the vehicle end up safe?)
  pause    SIGSTOP for ``--pause`` wall seconds, then SIGCONT
  restart  SIGKILL, then the same node started again at once
and reports:
  held after (sim s)   from the fault to the vehicle holding station (a pose kept >= 0.5 wall s; "-": it
                       never had to, the mission went on; "clock" where the vehicle node itself stopped,
                       so the clock stands; in lockstep the clock stands at the next decision boundary)
  (missed)             the same from the first decision that did not come (the watchdog's own measure:
                       the requirement is <= 1 sim s)
  recovered (wall s)   from SIGCONT / the restart to the next decision flown (first setpoint stamped
                       later than the fault), "-" if none
  outcome              the judge's outcome (goal / collision / wander / timeout) or "none" (no outcome
                       within ``--wait`` wall seconds after the fault: the vehicle waits, safe)
  collision            whether any collision was judged (the "safe" criterion)
Ends with one JSON line. Heavy (a graph per row, ~30 s each): run on a quiet machine.

    .venv/bin/python benchmarks/bench_faults.py [--modes free lockstep] [--nodes policy_node sim_node ...]
                                                [--faults kill pause restart] [--at 10] [--pause 3] [--wait 40]
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "tests/faults"), str(ROOT / "tests/graph")]

PERIOD_NS = 1_000_000_000   # one decision: step_length / speed of config/graph.yaml (1 m at 1 m/s)
NODES = ["policy_node", "sim_node", "vehicle_node", "rrt_node", "navigator_node"]


def first_hold(poses, after_ns: int, hold_wall: float = 0.5) -> int | None:
    """Sim time (ns) of the first pose after ``after_ns`` that the vehicle kept for ``hold_wall`` wall
    seconds or more (a real hold, not a decision boundary's brief wait), or None."""
    for i, (w, t, x, y) in enumerate(poses):
        if t < after_ns:
            continue
        j = i
        while j + 1 < len(poses) and abs(poses[j + 1][2] - x) < 1e-9 and abs(poses[j + 1][3] - y) < 1e-9:
            j += 1
        if poses[j][0] - w >= hold_wall:
            return t
    return None


def run_one(mode: str, node: str, fault: str, at: float, pause: float, wait: float, domain: int, logdir: Path) -> dict:
    from cage_planner_msgs.msg import HeadingSetpoint
    from nav_msgs.msg import Odometry
    from cage_sim.ros_convert import EVENT_OUTCOMES, stamp_ns
    from graphrig import GraphRig

    rig = GraphRig(logdir, domain, time_scale=20.0, lockstep=(mode == "lockstep"), timeout=120.0)
    arrivals: list[tuple[float, int]] = []           # (wall, stamp) of each decision flown (not failsafes)
    poses: list[tuple[float, int, float, float]] = []     # (wall, sim ns, x, y) of every odometry message
    rig.probe.node.create_subscription(HeadingSetpoint, "/cage/heading_setpoint",
                                       lambda m: m.source != HeadingSetpoint.SOURCE_FAILSAFE and arrivals.append(
                                           (time.monotonic(), stamp_ns(m.header.stamp))), 10)
    rig.probe.node.create_subscription(
        Odometry, "/cage/odom", lambda m: poses.append((time.monotonic(), stamp_ns(m.header.stamp),
                                                        m.pose.pose.position.x, m.pose.pose.position.y)), 100)
    row = {"mode": mode, "node": node, "fault": fault}
    try:
        rig.start_all()
        if not rig.wait(lambda: rig.sim_time() >= at or rig.outcomes(), 120):
            return {**row, "error": "the mission did not reach the fault time"}
        t_fault_ns, fault_wall = int(rig.sim_time() * 1e9), time.monotonic()
        if fault == "pause":
            rig.pause(node)
            rig.idle(pause)
            rig.resume(node)
            back = time.monotonic()
        elif fault == "restart":
            rig.restart(node)
            back = time.monotonic()
        else:
            rig.kill(node)
            back = None
        rig.wait(lambda: rig.result() is not None or (rig.outcomes() and back is None), wait)
        if back is None:
            rig.idle(2.0)
        held = first_hold(poses, t_fault_ns)
        ends = [stamp_ns(e.header.stamp) for e in rig.events if e.event in EVENT_OUTCOMES]
        if held is not None and ends and held >= ends[0]:
            held = None   # the hold after the outcome is the mission's end, not the fault's doing
        # the first decision that did not come: one period after the last setpoint flown before the fault
        due = max((st for w, st in arrivals if w <= fault_wall), default=0) + PERIOD_NS
        if node == "vehicle_node" and fault != "restart":
            held_s = due_s = "clock"
        else:
            held_s = "-" if held is None else f"{(held - t_fault_ns) / 1e9:.2f}"
            due_s = "-" if held is None else f"{max(held - due, 0) / 1e9:.2f}"
        rec = next((t - back for t, s in arrivals if back is not None and t >= back and s > t_fault_ns), None)
        outcomes = rig.outcomes()
        return {**row, "held_after_sim_s": held_s, "held_after_missed_decision_sim_s": due_s, "recovered_wall_s": None if rec is None else round(rec, 2),
                "outcome": outcomes[-1] if outcomes else "none", "collision": "collision" in outcomes,
                "tracebacks": rig.tracebacks()}
    finally:
        rig.stop()


def free_domain() -> int:
    """A ROS_DOMAIN_ID with no DDS participant on it (scripts/free_domain.py): a graph sharing its
    domain with another run (a test, a colleague's graph) would answer the other's messages."""
    out = subprocess.run([sys.executable, str(ROOT / "scripts/free_domain.py")], capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"bench_faults: no free ROS_DOMAIN_ID: {out.stderr.strip()}")
    return int(out.stdout.strip())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--modes", nargs="+", default=["free"], choices=["free", "lockstep"])
    ap.add_argument("--nodes", nargs="+", default=NODES, choices=NODES)
    ap.add_argument("--faults", nargs="+", default=["kill", "pause", "restart"], choices=["kill", "pause", "restart"])
    ap.add_argument("--at", type=float, default=10.0, help="sim time of the fault (s)")
    ap.add_argument("--pause", type=float, default=3.0, help="SIGSTOP length (wall s)")
    ap.add_argument("--wait", type=float, default=40.0, help="wall s to wait for an outcome after the fault")
    ap.add_argument("--logs", type=Path, default=None, help="keep the node logs here")
    a = ap.parse_args()
    logroot = a.logs or Path(tempfile.mkdtemp(prefix="bench_faults_"))
    rows = []
    print(f"{'mode':9s} {'node':15s} {'fault':8s} {'held after':>11s} {'(missed)':>9s} {'recovered':>10s} "
          f"{'outcome':>9s} collision")
    for i, (mode, node, fault) in enumerate((m, n, f) for m in a.modes for n in a.nodes for f in a.faults):
        domain = free_domain()
        try:
            r = run_one(mode, node, fault, a.at, a.pause, a.wait, domain, logroot / f"{mode}-{node}-{fault}")
        except Exception as err:  # noqa: BLE001 - one broken row must not lose the table
            r = {"mode": mode, "node": node, "fault": fault, "error": f"{type(err).__name__}: {err}"}
        rows.append(r)
        if "error" in r:
            print(f"{mode:9s} {node:15s} {fault:8s} error: {r['error']}", flush=True)
            continue
        rec = "-" if r["recovered_wall_s"] is None else f"{r['recovered_wall_s']:.2f}"
        print(f"{mode:9s} {node:15s} {fault:8s} {r['held_after_sim_s']:>11s} "
              f"{r['held_after_missed_decision_sim_s']:>9s} {rec:>10s} {r['outcome']:>9s} "
              f"{'YES' if r['collision'] else 'no'}{'  tracebacks: ' + ','.join(r['tracebacks']) if r['tracebacks'] else ''}",
              flush=True)
    print(json.dumps({"bench": "faults", "at_sim_s": a.at, "pause_wall_s": a.pause, "rows": rows,
                      "collisions": sum(bool(r.get("collision")) for r in rows)}))


if __name__ == "__main__":
    main()
