"""mission_client: sends the scenario's goal to the navigator, follows the mission, reports the outcome.

The launch-free scripts end with it. It sends the goal on the navigator's ``navigate`` action
(cage_planner_msgs/action/Navigate) once the server is there, so start-up order does not matter,
prints the feedback, and when the result comes writes a PNG of the track and one ``RESULT {json}``
line, then exits: 0 for goal, 1 for any other outcome of a flown mission, 2 for a rejected goal or a
planner failure, 3 when ``timeout`` wall seconds pass first. Where the rclpy in use has no actions it
publishes the goal on ``goal_pose`` instead (re-sent until the navigator answers with a mission) and
reads the outcome from ``mission_event``.

A navigator restarted mid-mission has forgotten the action goal, so its result never comes; the
simulator still judges the mission and says the outcome on ``mission_event``. When that event has
come and no action result follows within ``result_grace`` wall seconds, the client reports the
judged outcome (saying why) instead of waiting for its timeout.
"""
from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path as FsPath

import rclpy
from cage_planner_msgs.msg import Mission, MissionEvent
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Path
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from ..navigation import CODE_NAMES
from .node_common import declare
from ..plotting import plot_episode
from ..ros_convert import EVENT_OUTCOMES, path_points, yaw_to_quaternion
from ..scenarios import draw_scenario

try:
    from rclpy.action import ActionClient
    from cage_planner_msgs.action import Navigate
except ImportError:  # pragma: no cover - depends on the rclpy in use
    ActionClient = None

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
EXIT = {"goal": 0, "collision": 1, "wander": 1, "timeout": 1, "preempted": 1, "canceled": 1, "navigator_stopped": 1,
        "planner_failed": 2, "rejected": 2, "wall_timeout": 3}


class MissionClient(Node):
    def __init__(self) -> None:
        super().__init__("mission_client")
        self.p = declare(self, scenario="full_cage", seed=0, timeout=120.0, png="out/mission_track.png",
                         progress_every=10, resend_period=2.0, frame_id="map", use_action=True, result_grace=3.0)
        if not (isinstance(self.p["progress_every"], int) and self.p["progress_every"] >= 1):
            raise ValueError(f"parameter progress_every:={self.p['progress_every']!r} is invalid: must be an integer >= 1")
        grace = self.p["result_grace"]
        if not (isinstance(grace, (int, float)) and math.isfinite(grace) and grace > 0):
            raise ValueError(f"parameter result_grace:={grace!r} is invalid: must be > 0 wall seconds")
        self.judged: tuple[float, MissionEvent] | None = None   # the simulator's outcome event, when it came
        self.scenario = draw_scenario(self.p["scenario"], self.p["seed"])
        self.started = time.monotonic()
        self.result: dict | None = None
        self.plan = None
        self.track: list[tuple[float, float, float]] = []
        self.last_progress = -1
        self.goal_sent_at = -math.inf
        self.mission_id: int | None = None
        self.create_subscription(MissionEvent, "mission_event", self.on_event, 10)
        self.create_subscription(Mission, "mission", self.on_mission, LATCHED)
        self.create_subscription(Path, "plan", self.on_plan, LATCHED)
        self.create_subscription(Path, "track", self.on_track, LATCHED)
        self.action = None
        if ActionClient is not None and self.p["use_action"]:
            self.action = ActionClient(self, Navigate, "navigate")
            self.goal_future = None
        else:
            self.get_logger().info("no actions in this rclpy: sending the goal on goal_pose")
            self.goal_pub = self.create_publisher(PoseStamped, "goal_pose", 10)
        self.create_timer(0.2, self.send_goal)

    def goal_pose(self) -> PoseStamped:
        goal = PoseStamped()
        goal.header.frame_id = self.p["frame_id"]
        goal.header.stamp = self.get_clock().now().to_msg()
        goal.pose.position.x, goal.pose.position.y = map(float, self.scenario.goal)
        goal.pose.orientation = yaw_to_quaternion(0.0)
        return goal

    # --- sending -----------------------------------------------------------------------------
    def send_goal(self) -> None:
        if self.result is not None:
            return
        if self.action is not None:
            if self.goal_future is None and self.action.server_is_ready():
                self.goal_future = self.action.send_goal_async(Navigate.Goal(pose=self.goal_pose()),
                                                               feedback_callback=self.on_feedback)
                self.goal_future.add_done_callback(self.on_goal_response)
                self.log_goal()
            return
        if self.mission_id is not None or time.monotonic() - self.goal_sent_at < self.p["resend_period"]:
            return
        if self.goal_pub.get_subscription_count() > 0:
            self.goal_pub.publish(self.goal_pose())
            self.goal_sent_at = time.monotonic()
            self.log_goal()

    def log_goal(self) -> None:
        self.get_logger().info(f"goal sent: ({self.scenario.goal[0]:.2f}, {self.scenario.goal[1]:.2f})")

    def on_goal_response(self, future) -> None:
        handle = future.result()
        if not handle.accepted:
            self.finish("rejected", detail="the navigator rejected the goal (its log says why)")
            return
        self.get_logger().info("goal accepted")
        handle.get_result_async().add_done_callback(self.on_result)

    def on_feedback(self, msg) -> None:
        fb = msg.feedback
        self.mission_id = fb.mission_id
        k = int(fb.navigation_time.sec)
        if self.result is None and k % self.p["progress_every"] == 0 and k > self.last_progress and k > 0:
            self.last_progress = k
            p = fb.current_pose.pose.position
            print(f"[mission] t={k:4d} s  pose=({p.x:6.2f}, {p.y:6.2f})  {fb.distance_remaining:5.1f} m to go, "
                  f"{fb.decisions} decisions, {fb.shield_interventions} shielded", flush=True)

    def on_result(self, future) -> None:
        r = future.result().result
        self.finish(CODE_NAMES.get(r.outcome, f"code {r.outcome}"), steps=int(r.decisions), detail=r.detail,
                    final=(r.final_position.x, r.final_position.y), mission_id=int(r.mission_id),
                    path_length=round(float(r.path_length), 3))

    # --- following (topics: the plot, and the outcome without actions) -----------------------------
    def on_mission(self, msg: Mission) -> None:
        if self.action is None and self.goal_sent_at > -math.inf and msg.state == Mission.ACTIVE and \
                math.dist((msg.goal.x, msg.goal.y), self.scenario.goal) < 1e-6:
            self.mission_id = msg.id

    def on_plan(self, msg: Path) -> None:
        self.plan = path_points(msg)

    def on_track(self, msg: Path) -> None:
        self.track = [(p.pose.position.x, p.pose.position.y, 0.0) for p in msg.poses]

    def on_event(self, msg: MissionEvent) -> None:
        if self.mission_id is None or msg.mission_id != self.mission_id:
            return
        if msg.event in EVENT_OUTCOMES:
            if self.action is None:
                self.finish_judged(msg)
            elif self.judged is None:
                self.judged = (time.monotonic(), msg)    # the action's result normally follows at once
        elif msg.event in (MissionEvent.FAILSAFE, MissionEvent.REPLAN_REQUESTED):
            self.get_logger().warning(f"mission event {msg.event}: {msg.detail}")

    def finish_judged(self, msg: MissionEvent, why: str = "") -> None:
        self.finish(EVENT_OUTCOMES[msg.event], steps=int(msg.step), detail=why + msg.detail,
                    final=(msg.position.x, msg.position.y), mission_id=int(msg.mission_id))

    def check_wall_timeout(self) -> None:
        if self.result is not None:
            return
        now = time.monotonic()
        if self.judged is not None and now - self.judged[0] > self.p["result_grace"]:
            self.get_logger().warning(f"no action result {self.p['result_grace']:.1f} s after the simulator's "
                                      f"outcome (navigator restarted?): reporting the judged outcome")
            self.finish_judged(self.judged[1], "judged by the simulator (no action result): ")
        elif now - self.started > self.p["timeout"]:
            self.finish("wall_timeout", detail=f"no outcome within {self.p['timeout']} s")

    def finish(self, outcome: str, steps: int = 0, detail: str = "", final=None, **extra) -> None:
        if self.result is not None:
            return
        self.result = {"outcome": outcome, "steps": steps, "detail": detail, "scenario": self.scenario.name,
                       "seed": self.p["seed"], "wall_s": round(time.monotonic() - self.started, 2),
                       "final": list(final) if final else None, **extra}
        png = self.p["png"]
        if png and self.track:
            FsPath(png).parent.mkdir(parents=True, exist_ok=True)
            sc = self.scenario
            plot_episode(png, sc.world, self.track, outcome, sc.start, sc.goal,
                         self.plan if self.plan is not None and len(self.plan) else None,
                         title=f"{sc.name} (node graph): {outcome} in {steps} decisions")
            self.result["png"] = png
        print(f"[mission] outcome: {outcome}. {detail}", flush=True)
        print("RESULT " + json.dumps(self.result), flush=True)


def main(args=None) -> None:
    rclpy.init(args=args)
    try:
        node = MissionClient()
    except ValueError as err:
        rclpy.logging.get_logger("mission_client").fatal(f"cannot start: {err}")
        rclpy.try_shutdown()
        sys.exit(2)
    code = 130
    try:
        while rclpy.ok() and node.result is None:
            rclpy.spin_once(node, timeout_sec=0.1)
            node.check_wall_timeout()
        if node.result is not None:
            code = EXIT.get(node.result["outcome"], 1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    sys.exit(code)


if __name__ == "__main__":
    main()
