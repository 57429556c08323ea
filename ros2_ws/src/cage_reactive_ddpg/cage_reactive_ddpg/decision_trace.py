"""One row per decision of an evaluated mission: what the vehicle knew, what it chose, what came of it.

Why: a failed mission in a matrix cell is understood decision by decision (which waypoint the route
held, how near the goal was, when the shield took over, when a replan came, what the clearance
was). Every such study so far began with a throwaway script that re-flew the mission by hand;
``evaluate --trace`` writes the rows from the evaluator's own loop instead, so the trace is the very
flight the table counted (``--only`` picks the missions). With ``--grace`` the rows go on past the
budget to how the mission really ended (the table still judges it at the budget). Pure Python.
"""
from __future__ import annotations

import csv
import math
from pathlib import Path

FIELDS = ("cell", "driver", "episode", "decision", "t", "x", "y", "yaw_deg", "waypoint", "last_waypoint",
          "to_waypoint", "heading_error_deg", "to_goal", "clearance", "action", "shielded", "goal_in_sight",
          "replans", "outcome")


def decision_row(m, episode: int, action: float, shielded: bool) -> dict:
    """The row of mission ``m`` (a ``cage_sim.mission.Mission``) at the decision about to be flown with
    ``action``: the pose, the route's waypoint and goal as the judge's tracker holds them, the true
    clearance to the world as it is now (what the collision test measures), and whether the shield
    replaced the driver's action. ``outcome`` is filled by the caller once the step is flown
    (``goal``, ``collision``, ``wander``, ``timeout``: on the mission's last row)."""
    dist, err = m.waypoint()
    gx, gy = m.route[-1]
    return {"episode": episode, "decision": m.steps, "t": round(m.t, 3), "x": round(m.x, 4), "y": round(m.y, 4),
            "yaw_deg": round(math.degrees(m.yaw), 2), "waypoint": m.index, "last_waypoint": len(m.route) - 1,
            "to_waypoint": round(dist, 4), "heading_error_deg": round(math.degrees(err), 2),
            "to_goal": round(math.hypot(gx - m.x, gy - m.y), 4),
            "clearance": round(m.scene.clearance(m.x, m.y, m.t), 4), "action": float(action),
            "shielded": int(bool(shielded)), "goal_in_sight": int(m.tracker.sighted), "replans": m.replans,
            "outcome": ""}


def write_trace(rows: list[dict], path: str | Path) -> None:
    """The rows as CSV (``FIELDS`` in order; ``cell`` and ``driver`` empty outside a matrix run)."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=FIELDS, restval="")
        w.writeheader()
        w.writerows(rows)
