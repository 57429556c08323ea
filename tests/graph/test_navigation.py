"""Missions as a service, across real processes: goal after goal on the Navigate action and on
/goal_pose, preemption, cancel (the vehicle holds station), rejection reasons, and two vehicles in
their own namespaces on one domain. Baseline driver and a high time scale keep them short."""
from __future__ import annotations

import math

from action_msgs.msg import GoalStatus
from cage_planner_msgs.msg import Mission, MissionEvent
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry

from cage_sim.navigation import CANCELED, GOAL_REACHED, PREEMPTED
from cage_sim.ros_convert import odom_pose
from cage_sim.scenarios import draw_scenario

from graph_testlib import ROOT

RRT = str(ROOT / "ros2_ws/src/cage_global_rrt/config/rrt.yaml")
GRAPH = str(ROOT / "ros2_ws/src/cage_sim/config/graph.yaml")


def start_graph(launch, ns: str = "/cage", scenario: str = "full_cage", seed: int = 0,
                time_scale: float = 100.0) -> dict:
    shared = ["-r", f"__ns:={ns}", "--params-file", GRAPH, "-p", f"scenario:={scenario}", "-p", f"seed:={seed}",
              "-p", f"time_scale:={time_scale}"]
    return {
        "navigator": launch("cage_sim", "navigator_node", *shared, "-r", "goal_pose:=/goal_pose",
                            "-p", f"planner_config:={RRT}"),
        "rrt": launch("cage_global_rrt", "rrt_node", "--params-file", RRT, *shared),
        "policy": launch("cage_reactive_ddpg", "policy_node", *shared, "-p", "policy:=baseline"),
        "vehicle": launch("cage_sim", "vehicle_node", *shared),
        "sim": launch("cage_sim", "sim_node", *shared),
    }


class Navigator:
    """An action client on <ns>/navigate in the probe node."""

    def __init__(self, probe, ns: str = "/cage", graph: dict | None = None):
        from rclpy.action import ActionClient
        from cage_planner_msgs.action import Navigate
        self.probe, self.Navigate = probe, Navigate
        self.client = ActionClient(probe.node, Navigate, f"{ns}/navigate")
        self.feedback: list = []
        assert probe.until(self.client.server_is_ready, 60), logs(graph or {})

    def send(self, x: float, y: float):
        goal = self.Navigate.Goal()
        goal.pose.header.frame_id = "map"
        goal.pose.pose.position.x, goal.pose.pose.position.y = float(x), float(y)
        sent = self.client.send_goal_async(goal, feedback_callback=lambda m: self.feedback.append(m.feedback))
        assert self.probe.until(sent.done, 20)
        return sent.result()

    def result(self, handle, timeout: float = 90.0):
        fut = handle.get_result_async()
        assert self.probe.until(fut.done, timeout), "no result"
        return fut.result()

    def progress(self, mission_id: int, decisions: int, timeout: float = 30.0) -> bool:
        return self.probe.until(lambda: any(f.mission_id == mission_id and f.decisions >= decisions
                                            for f in self.feedback), timeout)


def logs(graph: dict) -> str:
    return "\n".join(f"--- {k}\n{p.output[-3000:]}" for k, p in graph.items())


def test_goal_after_goal_on_the_action_and_goal_pose_and_rejections(launch, probe):
    sc = draw_scenario("full_cage", 0)
    graph = start_graph(launch)
    nav = Navigator(probe)
    events = probe.listen(MissionEvent, "/cage/mission_event")

    first = nav.send(*sc.goal)
    assert first.accepted, logs(graph)
    r1 = nav.result(first)
    assert r1.status == GoalStatus.STATUS_SUCCEEDED and r1.result.outcome == GOAL_REACHED, (r1, logs(graph))
    assert math.dist((r1.result.final_position.x, r1.result.final_position.y), sc.goal) < 1.0
    assert r1.result.decisions > 30 and r1.result.path_length > 40.0 and r1.result.navigation_time.sec > 30
    assert any(f.mission_id == r1.result.mission_id and f.distance_remaining > 0 for f in nav.feedback)

    second = nav.send(0.0, 0.0)                                   # a second goal, no restart
    r2 = nav.result(second)
    assert r2.result.outcome == GOAL_REACHED and r2.result.mission_id == r1.result.mission_id + 1, logs(graph)
    assert math.hypot(r2.result.final_position.x, r2.result.final_position.y) < 1.0

    goal_pub = probe.node.create_publisher(PoseStamped, "/goal_pose", 10)   # RViz's goal tool
    assert probe.until(lambda: goal_pub.get_subscription_count() > 0, 10)
    g = PoseStamped()
    g.header.frame_id = "map"
    g.pose.position.x, g.pose.position.y = -24.0, 6.0              # round a known obstacle: a corner
    goal_pub.publish(g)
    third = r2.result.mission_id + 1
    reached = lambda: any(e.mission_id == third and e.event == MissionEvent.GOAL_REACHED for e in events)  # noqa: E731
    assert probe.until(reached, 60), logs(graph)
    kinds = [e.event for e in events if e.mission_id == third]
    assert kinds[0] == MissionEvent.STARTED and kinds[-1] == MissionEvent.GOAL_REACHED, kinds
    assert MissionEvent.WAYPOINT_REACHED in kinds

    ob = sc.world.known[0]
    for (x, y), reason in (((40.0, 0.0), "GOAL_OUTSIDE_NET"), ((ob.x, ob.y), "GOAL_OCCUPIED")):
        h = nav.send(x, y)
        assert not h.accepted
        assert probe.until(lambda: reason in graph["navigator"].output, 5), graph["navigator"].output
    assert "Traceback" not in logs(graph)


def test_new_goal_preempts_and_cancel_holds_station(launch, probe):
    sc = draw_scenario("full_cage", 0)
    # 5x: one decision (1 m) per 0.2 s of wall time, so the ~28 m to the second goal take ~5 s and a
    # cancel delayed by a loaded CI machine still lands mid-flight (at 100x the vehicle once arrived first)
    graph = start_graph(launch, time_scale=5.0)
    nav = Navigator(probe)
    odoms = probe.listen(Odometry, "/cage/odom")
    missions = probe.listen(Mission, "/cage/mission", 10)

    first = nav.send(*sc.goal)
    assert first.accepted and nav.progress(1, 5), logs(graph)
    second = nav.send(0.0, 10.0)                                    # preempts the first
    r1 = nav.result(first, 20)
    assert r1.status == GoalStatus.STATUS_ABORTED and r1.result.outcome == PREEMPTED, r1
    assert nav.progress(2, 5), logs(graph)                           # the new mission is flown (its own count)

    cancel = second.cancel_goal_async()
    assert probe.until(cancel.done, 10)
    r2 = nav.result(second, 20)
    assert r2.status == GoalStatus.STATUS_CANCELED and r2.result.outcome == CANCELED, r2
    assert probe.until(lambda: any(m.id == 2 and m.state == Mission.CANCELED for m in missions), 5)
    probe.until(lambda: False, 0.5)                                 # messages in flight settle
    n = len(odoms)
    probe.until(lambda: False, 1.5)                                 # 7 decisions at 5x, were it flying
    held = [odom_pose(o)[:2] for o in odoms[n:]]
    assert len(held) >= 5 and max(math.dist(p, held[0]) for p in held) < 1e-9, "the vehicle holds station"
    assert math.dist(held[0], (0.0, 10.0)) > 1.0                    # ... where it was, not at the goal

    third = nav.send(*sc.goal)                                      # and flies again afterwards
    r3 = nav.result(third)
    assert r3.result.outcome == GOAL_REACHED and r3.result.mission_id == 3, logs(graph)
    assert "Traceback" not in logs(graph)


def test_two_namespaced_vehicles_do_not_cross(launch, probe):
    one, two = draw_scenario("study2d", 1), draw_scenario("study2d", 2)
    g1 = start_graph(launch, "/auv1", "study2d", 1)
    g2 = start_graph(launch, "/auv2", "study2d", 2)
    odom1, odom2 = probe.listen(Odometry, "/auv1/odom"), probe.listen(Odometry, "/auv2/odom")
    n1, n2 = Navigator(probe, "/auv1", g1), Navigator(probe, "/auv2", g2)
    h1, h2 = n1.send(*one.goal), n2.send(*two.goal)
    assert h1.accepted and h2.accepted
    r1, r2 = n1.result(h1), n2.result(h2)
    assert r1.result.outcome == GOAL_REACHED, logs(g1)
    assert r2.result.outcome == GOAL_REACHED, logs(g2)
    assert r1.result.mission_id == r2.result.mission_id == 1           # each navigator its own missions
    assert math.dist(odom_pose(odom1[-1])[:2], one.goal) < 1.0
    assert math.dist(odom_pose(odom2[-1])[:2], two.goal) < 1.0
    assert math.dist(odom_pose(odom1[0])[:2], one.start[:2]) < 1e-6   # /auv1/odom only ever carried vehicle 1
    assert all(math.dist(odom_pose(o)[:2], two.start[:2]) > 1e-3 for o in odom1)
    assert "Traceback" not in logs(g1) + logs(g2)
