"""navigator_node: missions as a service, the way Nav2's bt_navigator serves NavigateToPose.

Action server ``navigate`` (cage_planner_msgs/action/Navigate) and the RViz goal topic ``goal_pose``
(the scripts remap it to /goal_pose) start a mission the same way:

1. the goal is checked against the known map (``map``) with the planner's own validity test and the
   planner's clearance (read from rrt_node's own rrt.yaml, as the evaluator reads it; parameter
   ``planner_config`` names another file): a goal in an obstacle or outside the net is rejected,
   and the reason is logged;
2. accepted, it preempts the running mission (its goal ends ABORTED with PREEMPTED), gets the next
   mission id and is sent to rrt_node (``plan_request``, stamped; the answer on ``plan`` /
   ``planner_status`` carries the same stamp, so a late answer for an old goal is never taken);
3. the route goes out on ``mission`` (latched) with the id: the simulator starts judging it at the
   next decision boundary, the policy follows it, the vehicle flies it; a replan from rrt_node comes
   back under the same id;
4. feedback (pose, distance to go, decisions, shield interventions, time) follows odometry and
   setpoints (the distance along the route as the judge's tracker measures it, the goal in sight
   across the known map included); the simulator's outcome on ``mission_event`` ends the goal:
   SUCCEEDED for the goal, ABORTED for a collision, wander, timeout or planner failure. Cancel
   publishes the mission as CANCELED: the vehicle holds station and the goal ends CANCELED.

Where the rclpy in use has no actions, the node serves ``goal_pose`` alone and says so once.
"""
from __future__ import annotations

import math
import time

import numpy as np
from builtin_interfaces.msg import Duration
from cage_planner_msgs.msg import CageMap, HeadingSetpoint, Mission, MissionEvent, PlannerStatus
from geometry_msgs.msg import Point, PoseStamped
from nav_msgs.msg import Odometry, Path
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from ..map_points import MapPoints
from ..navigation import (CANCELED, CODE_NAMES, GOAL_REACHED, NAVIGATOR_STOPPED, OUTCOME_CODES, PLANNER_FAILED,
                         PREEMPTED, MissionProgress, goal_problem)
from .node_common import declare
from .node_runner import run_node
from ..ros_convert import (EVENT_OUTCOMES, map_to_world, mission_msg, odom_pose, path_points, stamp_ns, time_msg,
                          yaw_to_quaternion)

try:  # rclpy's action layer (the project's runtime grows it; real rclpy has it)
    from rclpy.action import ActionServer, CancelResponse, GoalResponse
    from cage_planner_msgs.action import Navigate
except ImportError:  # pragma: no cover - depends on the rclpy in use
    ActionServer = None

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
WAITING_CODES = (PlannerStatus.NO_MAP, PlannerStatus.NO_POSE)


class ActiveGoal:
    """One goal from request to result: its mission, the action goal handle (None for goal_pose)."""

    def __init__(self, mission_id: int, goal: tuple[float, float], request_ns: int, handle, future,
                 waypoint_radius: float, known: MapPoints | None = None):
        self.id, self.goal, self.request_ns = mission_id, goal, request_ns
        self.handle, self.future = handle, future
        self.progress = MissionProgress(mission_id, goal, waypoint_radius=waypoint_radius, known=known)
        self.flying = False          # a route has gone out on `mission`
        self.route: np.ndarray | None = None
        self.sent_wall = 0.0         # when the plan request last went out (wall s)
        self.result = None


class NavigatorNode(Node):
    def __init__(self) -> None:
        super().__init__("navigator_node")
        from cage_global_rrt.routes import node_options
        self.p = declare(self, frame_id="map", feedback_period=0.2, retry_period=1.0, waypoint_radius=2.0,
                         planner_config="")
        self.options = node_options(self.p["planner_config"] or None)   # rrt_node's own rrt.yaml
        self.kmap = None
        self.map_points: MapPoints | None = None   # the feedback tracker's goal in sight (route.RouteTracker)
        self.pose: tuple[int, tuple[float, float, float]] | None = None
        self.active: ActiveGoal | None = None
        self.next_id = 1
        self.last_request_ns = 0
        self.last_feedback_wall = 0.0

        self.mission_pub = self.create_publisher(Mission, "mission", LATCHED)
        self.request_pub = self.create_publisher(PoseStamped, "plan_request", 10)
        self.create_subscription(CageMap, "map", self.on_map, LATCHED)
        self.create_subscription(Odometry, "odom", self.on_odom, 10)
        self.create_subscription(Path, "plan", self.on_plan, LATCHED)
        self.create_subscription(PlannerStatus, "planner_status", self.on_status, LATCHED)
        self.create_subscription(MissionEvent, "mission_event", self.on_event, 10)
        self.create_subscription(HeadingSetpoint, "heading_setpoint", self.on_setpoint, 10)
        self.create_subscription(PoseStamped, "goal_pose", self.on_goal_pose, 10)
        # a restarted navigator goes on counting from the last mission the graph saw (latched)
        self.create_subscription(Mission, "mission", self.on_mission_seen, LATCHED)
        self.create_timer(self.p["retry_period"], self.retry_request)
        self.server = None
        if ActionServer is None:
            self.get_logger().warning("this rclpy has no actions: serving goal_pose only")
        else:
            self.server = ActionServer(self, Navigate, "navigate", execute_callback=self.execute,
                                       goal_callback=self.on_goal_request,
                                       handle_accepted_callback=self.on_accepted,
                                       cancel_callback=self.on_cancel)
        self.get_logger().info(f"navigator ready: action 'navigate', topic 'goal_pose'; goals checked with "
                               f"clearance {self.margin():.2f} m")

    def on_mission_seen(self, msg: Mission) -> None:
        if msg.id >= self.next_id:
            self.next_id = msg.id + 1
            self.get_logger().debug(f"missions go on from id {self.next_id}")

    # --- goal checks ---------------------------------------------------------------------------
    def margin(self) -> float:
        from cage_global_rrt.environment import CageEnvironment
        return CageEnvironment.check_margin(self.options)

    def problem(self, pose: PoseStamped) -> str | None:
        """Why this goal is refused (one line), or None. Without a map yet it cannot be checked: the
        planner then judges it (and rrt_node waits for the map)."""
        frame = pose.header.frame_id
        if frame and frame != self.p["frame_id"]:
            return f"goal in frame {frame!r}, expected {self.p['frame_id']!r}"
        goal = (pose.pose.position.x, pose.pose.position.y)
        if self.kmap is None:
            if not all(math.isfinite(v) for v in goal):
                return f"goal {goal} is not finite"
            return None
        from cage_global_rrt.geometry import point_valid
        k = self.kmap
        found = goal_problem(goal, k.net_radius, self.margin(), k.squares, k.circles, point_valid)
        return None if found is None else f"{found[0]}: {found[1]}"

    # --- goal sources ----------------------------------------------------------------------------
    def on_goal_pose(self, msg: PoseStamped) -> None:
        why = self.problem(msg)
        if why is not None:
            self.get_logger().warning(f"goal_pose rejected: {why}")
            return
        self.start(msg, handle=None, future=None)

    def on_goal_request(self, goal_request) -> "GoalResponse":
        why = self.problem(goal_request.pose)
        if why is not None:
            self.get_logger().warning(f"goal rejected: {why}")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def on_accepted(self, handle) -> None:
        from rclpy.task import Future
        self.start(handle.request.pose, handle=handle, future=Future())
        handle.execute()

    def on_cancel(self, handle) -> "CancelResponse":
        a = self.active
        if a is not None and a.handle is not None and a.handle.goal_id == handle.goal_id:
            self.cancel_flight(a.id)
            self.finish(CANCELED, "canceled: holding station")
        return CancelResponse.ACCEPT

    async def execute(self, handle):
        active = self.active if self.active is not None and self.active.handle is handle else None
        future = active.future if active is not None else None
        if future is None:
            handle.abort()
            return Navigate.Result(outcome=NAVIGATOR_STOPPED, detail="goal lost before it started")
        result = await future
        if result.outcome == GOAL_REACHED:
            handle.succeed()
        elif result.outcome == CANCELED and handle.is_cancel_requested:
            handle.canceled()
        else:
            handle.abort()
        return result

    # --- the mission ---------------------------------------------------------------------------
    def start(self, pose: PoseStamped, handle, future) -> None:
        if self.active is not None:
            self.finish(PREEMPTED, f"preempted by mission {self.next_id}")
        goal = (float(pose.pose.position.x), float(pose.pose.position.y))
        now = self.get_clock().now().nanoseconds
        request_ns = max(now, self.last_request_ns + 1)   # unique: answers are matched by it
        self.last_request_ns = request_ns
        self.active = ActiveGoal(self.next_id, goal, request_ns, handle, future, self.p["waypoint_radius"],
                                 self.map_points)
        self.next_id += 1
        self.get_logger().info(f"mission {self.active.id}: goal ({goal[0]:.2f}, {goal[1]:.2f}) accepted"
                               f"{' (action)' if handle is not None else ' (goal_pose)'}; asking for a route")
        self.send_request()

    def send_request(self) -> None:
        a = self.active
        req = PoseStamped()
        req.header.stamp, req.header.frame_id = time_msg(a.request_ns), self.p["frame_id"]
        req.pose.position.x, req.pose.position.y = a.goal
        req.pose.orientation = yaw_to_quaternion(0.0)
        req.pose.orientation.w = 0.0  # no heading asked: an all-zero quaternion (rrt_node plans R^2)
        self.request_pub.publish(req)
        a.sent_wall = time.monotonic()

    def retry_request(self) -> None:
        """Re-send a request nobody has answered (rrt_node not up yet, or waiting for map/pose)."""
        a = self.active
        if (a is not None and not a.flying and a.result is None and self.request_pub.get_subscription_count() > 0
                and time.monotonic() - a.sent_wall >= self.p["retry_period"]):
            self.get_logger().debug(f"mission {a.id}: re-sending the plan request")
            self.send_request()

    def on_status(self, msg: PlannerStatus) -> None:
        a = self.active
        if a is None or a.result is not None or stamp_ns(msg.header.stamp) != a.request_ns:
            return
        if msg.code == PlannerStatus.SUCCESS or msg.code in WAITING_CODES:
            if msg.code in WAITING_CODES:
                self.get_logger().info(f"mission {a.id}: planner not ready ({msg.message}); will ask again")
            return
        if a.flying:
            self.get_logger().warning(f"mission {a.id}: replan failed (code {msg.code}: {msg.message}); "
                                      "keeping the current route")
            return
        self.cancel_flight(a.id)
        self.finish(PLANNER_FAILED, f"planner failed: code {msg.code}: {msg.message}")

    def on_plan(self, msg: Path) -> None:
        a = self.active
        if a is None or a.result is not None or stamp_ns(msg.header.stamp) != a.request_ns:
            return
        pts = path_points(msg)
        if len(pts) == 0 or not np.isfinite(pts).all():
            return  # a failed request: its status ends the goal
        if a.route is not None and a.route.shape == pts.shape and np.allclose(a.route, pts, atol=1e-9):
            return  # the same route again (an answer to a repeated request): nothing new to fly
        replan = a.flying
        a.flying, a.route = True, pts
        a.progress.set_route(pts, self.pose[1] if self.pose else None)
        now = self.pose[0] if self.pose else 0
        self.mission_pub.publish(mission_msg(a.id, Mission.ACTIVE, a.goal, pts, now, self.p["frame_id"]))
        self.get_logger().info(f"mission {a.id}: {'new route' if replan else 'route'} of {len(pts)} waypoints, "
                               f"{a.progress.path_length:.1f} m")

    def cancel_flight(self, mission_id: int) -> None:
        now = self.pose[0] if self.pose else 0
        self.mission_pub.publish(mission_msg(mission_id, Mission.CANCELED, (0.0, 0.0), [], now, self.p["frame_id"]))

    def on_event(self, msg: MissionEvent) -> None:
        a = self.active
        if a is None or a.result is not None or msg.mission_id != a.id:
            return
        pose = (msg.position.x, msg.position.y)
        if msg.event == MissionEvent.STARTED:
            a.progress.start(stamp_ns(msg.header.stamp), self.pose[1] if self.pose else pose)
            self.get_logger().info(f"mission {a.id}: started at t={stamp_ns(msg.header.stamp) / 1e9:.1f} s")
        elif msg.event == MissionEvent.WAYPOINT_REACHED:
            self.get_logger().debug(f"mission {a.id}: {msg.detail}")
        elif msg.event in EVENT_OUTCOMES:
            a.progress.on_pose(stamp_ns(msg.header.stamp), (pose[0], pose[1], a.progress.pose[2]
                                                             if a.progress.pose else 0.0))
            outcome = EVENT_OUTCOMES[msg.event]
            self.finish(OUTCOME_CODES[outcome], msg.detail, decisions=int(msg.step), final=pose)
        elif msg.event in (MissionEvent.FAILSAFE, MissionEvent.REPLAN_REQUESTED):
            self.get_logger().info(f"mission {a.id}: {msg.detail}")

    def on_setpoint(self, msg: HeadingSetpoint) -> None:
        a = self.active
        if a is not None and a.result is None and msg.mission_id == a.id:
            a.progress.on_setpoint(int(msg.decision), msg.source == HeadingSetpoint.SOURCE_SHIELD)

    def on_odom(self, msg: Odometry) -> None:
        pose = odom_pose(msg)
        if not all(math.isfinite(v) for v in pose):
            return
        t_ns = stamp_ns(msg.header.stamp)
        self.pose = (t_ns, pose)
        a = self.active
        if a is None or a.result is not None or a.progress.start_ns is None:
            return
        a.progress.on_pose(t_ns, pose)
        wall = self.get_clock().now().nanoseconds / 1e9
        if a.handle is not None and wall - self.last_feedback_wall >= self.p["feedback_period"]:
            self.last_feedback_wall = wall
            a.handle.publish_feedback(self.feedback(a))

    def feedback(self, a: ActiveGoal):
        fb = Navigate.Feedback(mission_id=a.id, distance_remaining=float(a.progress.distance_remaining()),
                               decisions=len(a.progress.decisions),
                               shield_interventions=len(a.progress.shielded),
                               navigation_time=duration_msg(a.progress.elapsed_ns))
        x, y, yaw = a.progress.pose
        fb.current_pose.header.stamp, fb.current_pose.header.frame_id = time_msg(a.progress.now_ns), self.p["frame_id"]
        fb.current_pose.pose.position.x, fb.current_pose.pose.position.y = float(x), float(y)
        fb.current_pose.pose.orientation = yaw_to_quaternion(yaw)
        return fb

    def finish(self, code: int, detail: str, decisions: int | None = None, final=None) -> None:
        """End the active goal with a result code (the action's execute coroutine reports it)."""
        a, self.active = self.active, None
        if a is None or a.result is not None:
            return
        pr = a.progress
        a.result = {"outcome": code, "detail": detail, "mission_id": a.id, "path_length": pr.path_length,
                    "distance_travelled": pr.travelled,
                    "decisions": decisions if decisions is not None else len(pr.decisions),
                    "elapsed_ns": pr.elapsed_ns,
                    "final": final if final is not None else (pr.pose[:2] if pr.pose else (math.nan, math.nan))}
        log = self.get_logger().info if code in (GOAL_REACHED, CANCELED, PREEMPTED) else self.get_logger().warning
        log(f"mission {a.id}: {CODE_NAMES[code]}: {detail}")
        if a.future is not None and not a.future.done():
            r = a.result
            a.future.set_result(Navigate.Result(
                outcome=code, detail=detail, mission_id=a.id, path_length=float(r["path_length"]),
                distance_travelled=float(r["distance_travelled"]), decisions=int(r["decisions"]),
                navigation_time=duration_msg(r["elapsed_ns"]),
                final_position=Point(x=float(r["final"][0]), y=float(r["final"][1]))))

    def on_map(self, msg: CageMap) -> None:
        """The known map: goals are checked against it, and the feedback's tracker flies to a goal in
        sight across it, as the simulator's judge and ``policy_node`` do (the same distance left)."""
        from cage_global_rrt.known_map import KnownMap
        try:
            world = map_to_world(msg)
            kmap, points = KnownMap.from_world(world), MapPoints.from_world(world)
        except ValueError as err:
            self.get_logger().error(f"map rejected: {err}")
            return
        self.kmap, self.map_points = kmap, points
        if self.active is not None:
            self.active.progress.set_known(points)
        self.get_logger().info(f"map: net {self.kmap.net_radius:g} m, {len(msg.obstacles)} known obstacles")

    def destroy_node(self) -> None:
        if self.active is not None:
            self.finish(NAVIGATOR_STOPPED, "the navigator shut down")
        super().destroy_node()


def duration_msg(ns: int) -> Duration:
    return Duration(sec=int(ns // 1_000_000_000), nanosec=int(ns % 1_000_000_000))


def main(args=None) -> None:
    run_node(NavigatorNode, args)


if __name__ == "__main__":
    main()
