"""rrt_node: the ROS 2 adapter over the planning core (``GlobalPlanner``).

Subscribes (relative names, so ``__ns:=/auv1`` moves it with its vehicle): ``map``
(cage_planner_msgs/CageMap, latched), ``odom`` (nav_msgs/Odometry), ``plan_request``
(geometry_msgs/PoseStamped: the navigator's goal), ``mission_event`` (REPLAN_REQUESTED replans to the
last goal from the current pose). Publishes, latched: ``plan`` (nav_msgs/Path in ``frame_id``) and
``planner_status`` (cage_planner_msgs/PlannerStatus) once per request, SUCCESS or the failure code,
both stamped with the request's stamp (a replan keeps it), so the navigator pairs each answer with
the goal it asked for. A failed request publishes an empty Path, so nobody keeps following a plan
made for another goal.

Net model (parameters ``net_model`` and ``current``, ``known_map``): ``current`` plans on the net
wall that the site's mean current (``current``: [vx, vy] m/s in the map frame, inside the pen, as
an ADCP or the vehicle's DVL estimate gives it) pushes in; ``nominal`` (the default) on the
surveyed circle of the map. Both can be changed at run time (``ros2 param set <ns>/rrt_node current
"[0.3, 0.0]"``): the planner map is rebuilt from the last map and the next plan uses it; the other
parameters are read at start, so changing them is refused with the reason.

Bad parameters stop the node at start with one clear message; bad input in a callback is logged
and published as a status, never raised.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from cage_planner_msgs.msg import CageMap, MissionEvent, PlannerStatus
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry, Path
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import LaserScan
from visualization_msgs.msg import Marker, MarkerArray

from cage_sim.nodes.node_common import start_only_reason
from cage_sim.nodes.node_runner import run_node
from cage_sim.ros_convert import map_to_world, odom_pose, path_msg, quaternion_to_yaw, stamp_ns

from ..known_map import KnownMap, net_model_error
from ..obstacle_layer import LayerParams, ObstacleLayer, plan_with_layer
from ..options import NODE_PARAMETERS, RUNTIME, InvalidParameters, options_from_parameters
from ..planner import GlobalPlanner, PlanResult
from ..status import PlanStatus

LATCHED = QoSProfile(depth=1, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)

class RrtNode(Node):
    def __init__(self) -> None:
        super().__init__("rrt_node")
        values = {name: self.declare_parameter(name, default).value for name, default in NODE_PARAMETERS.items()}
        self.frame_id = str(values["frame_id"])
        if not self.frame_id:
            raise InvalidParameters("parameter frame_id must not be empty")
        self.planner = GlobalPlanner(options=options_from_parameters(values))
        err = net_model_error(values["net_model"], values["current"])
        if err:
            raise InvalidParameters(f"parameter {err}")
        self.net_model, self.current = str(values["net_model"]), tuple(float(v) for v in values["current"])
        self.map_world = None                  # the last map received (rebuilt when the net model changes)
        self.pose: tuple[float, float, float] | None = None
        self.goal: tuple[float, ...] | None = None
        self.request_ns: int | None = None     # stamp of the request being answered
        self.waiting_for_map = False
        self.plan_pub = self.create_publisher(Path, "plan", LATCHED)
        self.status_pub = self.create_publisher(PlannerStatus, "planner_status", LATCHED)
        self.create_subscription(CageMap, "map", self._guard(self.on_map), LATCHED)
        self.create_subscription(Odometry, "odom", self._guard(self.on_odom, report=False), 10)
        self.create_subscription(PoseStamped, "plan_request", self._guard(self.on_goal), 10)
        self.create_subscription(MissionEvent, "mission_event", self._guard(self.on_event), 10)
        # Obstacle layer (parameter obstacle_layer): sonar returns confirmed over several scans become
        # temporary obstacles for every later plan; published as markers on ``obstacle_layer``.
        self.layer: ObstacleLayer | None = None
        self.layer_params: LayerParams | None = None
        if values["obstacle_layer"]:
            self.layer_params = LayerParams.from_parameters(values)
            err = self.layer_params.error()
            if err:
                raise InvalidParameters(f"parameter {err}")
            self.layer_pub = self.create_publisher(MarkerArray, "obstacle_layer", LATCHED)
            self.create_subscription(LaserScan, "scan", self._guard(self.on_scan, report=False),
                                     qos_profile_sensor_data)
            self.layer_version = -1
            self.last_scan_ns: int | None = None
        self.add_on_set_parameters_callback(self.on_set_parameters)
        o = self.planner.options
        self.get_logger().info(f"rrt_node ready: {o.planner}, step {o.max_step} m, clearance {o.clearance} m, "
                               f"dubins {o.dubins}, net {self._net_text()}, frame {self.frame_id}")

    def _net_text(self) -> str:
        return self.net_model if self.net_model == "nominal" else \
            f"{self.net_model} ({math.hypot(*self.current):.2f} m/s)"

    def on_set_parameters(self, params):
        """``net_model`` and ``current`` take effect at the next plan (the map is rebuilt now); the
        other parameters are read at start only, so changing them is refused with the reason."""
        from rcl_interfaces.msg import SetParametersResult
        model, current = self.net_model, self.current
        for prm in params:
            if prm.name in NODE_PARAMETERS and prm.name not in RUNTIME:
                return SetParametersResult(successful=False,
                                           reason=start_only_reason(prm.name))
            if prm.name == "net_model":
                model = prm.value
            elif prm.name == "current":
                current = prm.value     # a list here, an array.array in rclpy: checked below
        err = net_model_error(model, current)
        if err:
            return SetParametersResult(successful=False, reason=err)
        self.net_model, self.current = str(model), tuple(float(v) for v in current)
        if self.map_world is not None:
            self.set_known(self.known_map(self.map_world))
        self.get_logger().info(f"net model {self._net_text()} from the next plan")
        return SetParametersResult(successful=True)

    # ------------------------------------------------------------------ callbacks

    def _guard(self, callback, report: bool = True):
        """Run a callback so that no exception escapes into the executor: log it and (for requests
        and maps, not for the odometry stream) publish it as an INVALID_INPUT status."""
        def guarded(msg) -> None:
            try:
                callback(msg)
            except Exception as err:  # noqa: BLE001 - a callback must never raise
                self.get_logger().error(f"{callback.__name__}: {type(err).__name__}: {err}")
                if report:
                    self.publish(PlanResult(PlanStatus.INVALID_INPUT, f"{callback.__name__}: {err}"),
                                 clear_plan=False)
        return guarded

    def known_map(self, world) -> KnownMap:
        """The planner's map of the map message's ``world`` under the node's net model."""
        return KnownMap.from_world(replace(world, current=self.current), self.net_model)

    def set_known(self, known: KnownMap) -> None:
        """Plan on ``known`` from now on; an obstacle layer keeps what it has learnt."""
        self.planner.set_map(known)
        if self.layer is not None:
            self.layer.known = known
        self.planner.prepare()  # build the OMPL setup now, not in the next request

    def on_map(self, msg) -> None:
        try:
            world = map_to_world(msg)
            known = self.known_map(world)
        except ValueError as err:
            self.get_logger().error(f"map rejected: {err}")
            self.publish(PlanResult(PlanStatus.INVALID_INPUT, f"map rejected: {err}"), clear_plan=False)
            return
        self.map_world = world
        if self.layer_params is not None:   # a new map starts a new layer
            self.layer = ObstacleLayer(known, self.layer_params)
        self.set_known(known)
        self.get_logger().info(f"map: net {known.net_radius:g} m, {len(world.known)} obstacles, net model {self._net_text()}")
        if self.waiting_for_map and self.goal is not None:
            self.request()

    def on_odom(self, msg) -> None:
        pose = odom_pose(msg)
        if all(math.isfinite(v) for v in pose):
            self.pose = pose

    def on_goal(self, msg) -> None:
        self.request_ns = stamp_ns(msg.header.stamp)
        frame = msg.header.frame_id
        if frame and frame != self.frame_id:
            self.publish(PlanResult(PlanStatus.INVALID_INPUT, f"goal in frame {frame!r}, expected {self.frame_id!r}"))
            return
        p, q = msg.pose.position, msg.pose.orientation
        has_yaw = (q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w) > 1e-12
        self.goal = (p.x, p.y, quaternion_to_yaw(q)) if has_yaw else (p.x, p.y)
        self.request()

    def on_event(self, msg) -> None:
        if msg.event != MissionEvent.REPLAN_REQUESTED:
            return
        if self.goal is None:
            self.get_logger().warning("replan requested before any goal; ignored")
            return
        self.request()

    # ------------------------------------------------------------------ planning

    def request(self) -> None:
        """Plan from the current pose to the last goal and publish the outcome."""
        self.waiting_for_map = self.planner.kmap is None
        if self.planner.kmap is None:
            result = PlanResult(PlanStatus.NO_MAP, "no map received on the map topic yet")
        elif self.pose is None:
            result = PlanResult(PlanStatus.NO_POSE, "no pose received on the odom topic yet")
        else:
            # R^2 plans ignore headings; Dubins plans start at the vehicle's heading
            result = plan_with_layer(self.planner, self.layer, self.pose, self.goal)
        self.publish(result)

    def publish(self, result: PlanResult, clear_plan: bool = True) -> None:
        """Status always; the path on success, an empty path on a failed request (``clear_plan``)."""
        ns = self.request_ns if self.request_ns is not None else self.get_clock().now().nanoseconds
        if result.ok:
            pts = np.column_stack((result.waypoints, result.headings))
            self.plan_pub.publish(path_msg(pts, ns, self.frame_id))
        elif clear_plan:
            self.plan_pub.publish(path_msg([], ns, self.frame_id))
        status = status_msg(result, ns, self.frame_id)
        self.status_pub.publish(status)
        log = self.get_logger().info if result.ok else self.get_logger().warn
        log(f"plan {result.status.name}: {result.message} ({result.planning_time * 1e3:.2f} ms)")


    def on_scan(self, msg) -> None:
        """Feed the layer one scan from the latest pose; publish its obstacles when they change."""
        if self.layer is None or self.pose is None:
            return
        stamp = stamp_ns(msg.header.stamp)
        if stamp == self.last_scan_ns:
            return   # the same scan again (republished while the vehicle waits): not new evidence
        self.last_scan_ns = stamp
        ranges = np.asarray(msg.ranges, dtype=float)
        angles = msg.angle_min + msg.angle_increment * np.arange(len(ranges))
        ranges[~(ranges >= msg.range_min)] = np.inf     # below range_min or NaN: no echo
        self.layer.update(self.pose, ranges, angles, float(msg.range_max))
        if self.layer.version != self.layer_version:
            self.layer_version = self.layer.version
            self.layer_pub.publish(layer_markers(self.layer, self.get_clock().now().nanoseconds, self.frame_id))


def layer_markers(layer: ObstacleLayer, ns: int, frame_id: str) -> MarkerArray:
    """The layer's circles as cylinders (ns ``obstacle_layer``), after a DELETEALL."""
    clear = Marker(ns="obstacle_layer", id=0, action=Marker.DELETEALL)
    out = [clear]
    for i, ob in enumerate(layer.obstacles()):
        m = Marker(ns="obstacle_layer", id=i + 1, action=Marker.ADD, type=Marker.CYLINDER)
        m.pose.position.x, m.pose.position.y = ob.x, ob.y
        m.pose.orientation.w = 1.0
        m.scale.x = m.scale.y = 2.0 * ob.size
        m.scale.z = 0.5
        m.color.r, m.color.g, m.color.b, m.color.a = 1.0, 0.5, 0.0, 0.6
        out.append(m)
    for m in out:
        m.header.stamp.sec, m.header.stamp.nanosec = int(ns // 1_000_000_000), int(ns % 1_000_000_000)
        m.header.frame_id = frame_id
    return MarkerArray(markers=out)


def status_msg(result: PlanResult, ns: int, frame_id: str) -> PlannerStatus:
    msg = PlannerStatus()
    msg.header.stamp.sec, msg.header.stamp.nanosec = int(ns // 1_000_000_000), int(ns % 1_000_000_000)
    msg.header.frame_id = frame_id
    msg.code = int(result.status)
    msg.message = result.message
    msg.planning_time = float(result.planning_time)
    msg.n_waypoints = int(len(result.waypoints))
    return msg


def main(args=None) -> None:
    run_node(RrtNode, args)


if __name__ == "__main__":
    main()
