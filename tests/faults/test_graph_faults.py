"""Items 1-2 against the whole graph: every node killed (SIGKILL) and restarted mid-mission, one after
another, in lockstep at 20x: the mission still ends at the goal, with no collision and no traceback.
The restarted navigator has lost the client's action goal: the client reports the simulator's judged
outcome instead of waiting for a result that cannot come."""
from __future__ import annotations

import os

from graphrig import GraphRig


def test_every_node_restarted_mid_mission_and_the_goal_is_still_reached(tmp_path):
    rig = GraphRig(tmp_path, domain=(os.getpid() * 7) % 90 + 10, time_scale=20.0, lockstep=True, timeout=150.0)
    try:
        rig.start_all()
        assert rig.wait(lambda: rig.sim_time() >= 6.0, 90), rig.logs()
        for name, at in (("policy_node", 6.0), ("sim_node", 14.0), ("vehicle_node", 22.0), ("rrt_node", 30.0),
                         ("navigator_node", 36.0)):
            assert rig.wait(lambda: rig.sim_time() >= at or rig.outcomes(), 60), (name, rig.logs())
            assert not rig.outcomes(), (name, rig.outcomes())   # the mission must still be running
            t_fault = rig.sim_time()
            rig.restart(name)
            # the mission goes on: at least 3 more decisions flown with the new node
            assert rig.wait(lambda: rig.sim_time() >= t_fault + 3 or rig.outcomes(), 60), (name, rig.logs())
        assert rig.wait(lambda: rig.result() is not None, 120), rig.logs()
        assert rig.outcomes() == ["goal"], (rig.outcomes(), rig.logs())
        assert rig.result()["outcome"] == "goal" and "judged by the simulator" in rig.result()["detail"], rig.result()
        assert not rig.tracebacks(), rig.logs()
    finally:
        rig.stop()
