"""mission_client: sends the scenario's goal to the graph, follows the mission, reports the outcome.

The launch-free scripts end with it: it publishes the goal on /goal_pose (re-sent until the planner
answers, so start-up order does not matter), prints progress, and when the simulator announces the
outcome writes a PNG of the track and one ``RESULT {json}`` line, then exits: 0 for goal, 1 for any
other outcome, 2 for a planner failure, 3 when ``timeout`` wall seconds pass first.
"""
from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path as FsPath

import rclpy
from cage_planner_msgs.msg import MissionEvent, PlannerStatus
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry, Path
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from .node_common import declare
from .plotting import plot_episode
from .ros_convert import EVENT_OUTCOMES, odom_pose, path_points, stamp_ns, yaw_to_quaternion
from .scenarios import draw_scenario

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
EXIT = {"goal": 0, "collision": 1, "wander": 1, "timeout": 1, "planner_failure": 2, "wall_timeout": 3}


class MissionClient(Node):
    def __init__(self) -> None:
        super().__init__("mission_client")
        self.p = declare(self, scenario="full_cage", seed=0, timeout=120.0, png="out/mission_track.png",
                         progress_every=10, resend_period=2.0, frame_id="map")
        self.scenario = draw_scenario(self.p["scenario"], self.p["seed"])
        self.started = time.monotonic()
        self.result: dict | None = None
        self.plan = None
        self.track: list[tuple[float, float, float]] = []
        self.last_progress = -1
        self.goal_sent_at = -math.inf
        self.planner_answered = False
        self.goal_pub = self.create_publisher(PoseStamped, "/goal_pose", 10)
        self.create_subscription(MissionEvent, "/cage/mission_event", self.on_event, 10)
        self.create_subscription(PlannerStatus, "/cage/planner_status", self.on_status, LATCHED)
        self.create_subscription(Path, "/cage/plan", self.on_plan, LATCHED)
        self.create_subscription(Path, "/cage/track", self.on_track, LATCHED)
        self.create_subscription(Odometry, "/cage/odom", self.on_odom, 10)
        self.create_timer(0.2, self.send_goal_until_answered)

    def send_goal_until_answered(self) -> None:
        if self.planner_answered or time.monotonic() - self.goal_sent_at < self.p["resend_period"]:
            return
        if self.goal_pub.get_subscription_count() == 0:
            return
        goal = PoseStamped()
        goal.header.frame_id = self.p["frame_id"]
        goal.header.stamp = self.get_clock().now().to_msg()
        goal.pose.position.x, goal.pose.position.y = map(float, self.scenario.goal)
        goal.pose.orientation = yaw_to_quaternion(0.0)
        self.goal_pub.publish(goal)
        self.goal_sent_at = time.monotonic()
        self.get_logger().info(f"goal sent: ({self.scenario.goal[0]:.2f}, {self.scenario.goal[1]:.2f})")

    def on_status(self, msg: PlannerStatus) -> None:
        if self.goal_sent_at == -math.inf:
            return  # an old latched status from before our goal
        if msg.code == PlannerStatus.SUCCESS:
            self.planner_answered = True
            self.get_logger().info(f"plan: {msg.n_waypoints} waypoints in {1000 * msg.planning_time:.1f} ms")
        elif msg.code in (PlannerStatus.NO_POSE, PlannerStatus.NO_MAP):
            self.get_logger().info(f"planner not ready ({msg.message}); will re-send the goal")
        else:
            self.planner_answered = True
            self.finish("planner_failure", detail=f"planner failed: code {msg.code}: {msg.message}")

    def on_plan(self, msg: Path) -> None:
        self.plan = path_points(msg)

    def on_track(self, msg: Path) -> None:
        self.track = [(p.pose.position.x, p.pose.position.y, 0.0) for p in msg.poses]

    def on_odom(self, msg: Odometry) -> None:
        k = stamp_ns(msg.header.stamp) // 1_000_000_000
        if self.result is None and k % self.p["progress_every"] == 0 and k > self.last_progress and k > 0:
            self.last_progress = k
            x, y, _ = odom_pose(msg)
            gx, gy = self.scenario.goal
            print(f"[mission] t={k:4d} s  pose=({x:6.2f}, {y:6.2f})  {math.hypot(gx - x, gy - y):5.1f} m to goal",
                  flush=True)

    def on_event(self, msg: MissionEvent) -> None:
        if msg.event in EVENT_OUTCOMES:
            self.finish(EVENT_OUTCOMES[msg.event], steps=int(msg.step), detail=msg.detail,
                        final=(msg.position.x, msg.position.y))
        elif msg.event in (MissionEvent.FAILSAFE, MissionEvent.REPLAN_REQUESTED):
            self.get_logger().warning(f"mission event {msg.event}: {msg.detail}")

    def check_wall_timeout(self) -> None:
        if self.result is None and time.monotonic() - self.started > self.p["timeout"]:
            self.finish("wall_timeout", detail=f"no outcome within {self.p['timeout']} s")

    def finish(self, outcome: str, steps: int = 0, detail: str = "", final=None) -> None:
        if self.result is not None:
            return
        self.result = {"outcome": outcome, "steps": steps, "detail": detail, "scenario": self.scenario.name,
                       "seed": self.p["seed"], "wall_s": round(time.monotonic() - self.started, 2),
                       "final": list(final) if final else None}
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
            code = EXIT[node.result["outcome"]]
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    sys.exit(code)


if __name__ == "__main__":
    main()
