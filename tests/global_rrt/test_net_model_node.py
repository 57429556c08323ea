"""rrt_node's net model over real DDS between real processes: with ``net_model:=current`` and the
site's current it plans on the wall the current pushes in (a goal between that wall and the map's
circle is refused, a route keeps its clearance from the real wall); ``ros2 param set`` switches the
model at run time, and refuses a bad current or a parameter read at start only, with the reason."""
from __future__ import annotations

import math

import numpy as np
from cage_planner_msgs.msg import PlannerStatus
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry, Path
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from cage_sim.ros_convert import time_msg, world_to_map, yaw_to_quaternion
from cage_sim.world import Obstacle, World

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
CURRENT = (0.0, -0.4)            # towards -y: the wall at +y (upstream) is pushed in


def _value(v) -> ParameterValue:
    if isinstance(v, str):
        return ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=v)
    if isinstance(v, list):
        return ParameterValue(type=ParameterType.PARAMETER_DOUBLE_ARRAY, double_array_value=[float(x) for x in v])
    return ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=float(v))


def test_net_model_plans_on_the_pushed_in_wall_and_switches_at_run_time(rig):
    probe, launch = rig
    real = World(30.0, (Obstacle("circle", 0.0, 10.5, 2.0),), (), CURRENT, net_loss=None)
    net = real.net
    start, goal = net.inward(math.radians(70), 4.0), net.inward(math.radians(110), 4.0)
    crescent = (0.0, 25.0)       # inside the map's circle, outside the wall the current pushes in
    assert net.clearance(*crescent) < 0.0 < math.hypot(*crescent) < 29.0

    paths = probe.listen(Path, "/cage/plan", LATCHED)
    statuses = probe.listen(PlannerStatus, "/cage/planner_status", LATCHED)
    map_pub = probe.node.create_publisher(type(world_to_map(real, 0)), "/cage/map", LATCHED)
    odom_pub = probe.node.create_publisher(Odometry, "/cage/odom", 10)
    goal_pub = probe.node.create_publisher(PoseStamped, "/cage/plan_request", 10)
    node = launch("-p", "net_model:=current", "-p", f"current:=[{CURRENT[0]}, {CURRENT[1]}]")
    map_pub.publish(world_to_map(real, 0))     # the map message: the nominal circle and the known obstacle
    assert probe.until(lambda: goal_pub.get_subscription_count() > 0 and "net model current" in node.output, 20), \
        node.output
    odom = Odometry()
    odom.header.frame_id = "map"
    odom.pose.pose.position.x, odom.pose.pose.position.y = start
    odom.pose.pose.orientation = yaw_to_quaternion(0.0)
    odom_pub.publish(odom)
    probe.until(lambda: False, 0.3)

    def ask(xy, k: int) -> PlannerStatus:
        msg = PoseStamped()
        msg.header.frame_id, msg.header.stamp = "map", time_msg(k * 1_000_000_000)
        msg.pose.position.x, msg.pose.position.y = xy
        n = len(statuses)
        goal_pub.publish(msg)
        assert probe.until(lambda: len(statuses) > n, 10), node.output
        return statuses[-1]

    assert ask(crescent, 1).code == PlannerStatus.GOAL_OCCUPIED      # beyond the real wall
    assert ask(goal, 2).code == PlannerStatus.SUCCESS, node.output
    pts = np.array([(p.pose.position.x, p.pose.position.y) for p in paths[-1].poses])
    for a, b in zip(pts[:-1], pts[1:]):
        assert min(net.clearance(*(a + s * (b - a))) for s in np.linspace(0, 1, 60)) >= 1.0 - 1e-6

    client = probe.node.create_client(SetParameters, "/cage/rrt_node/set_parameters")
    assert probe.until(client.service_is_ready, 15)

    def set_param(name, value):
        fut = client.call_async(SetParameters.Request(parameters=[Parameter(name=name, value=_value(value))]))
        assert probe.until(fut.done, 10)
        return fut.result().results[0]

    refused = set_param("max_step", 2.0)                            # read at start only
    assert not refused.successful and "restart" in refused.reason
    fast = set_param("current", [1.2, 0.0])                         # as fast as the vehicle or faster
    assert not fast.successful and "not slower than the vehicle" in fast.reason
    bad = set_param("net_model", "tidal")
    assert not bad.successful and "net_model" in bad.reason
    assert set_param("net_model", "nominal").successful
    assert probe.until(lambda: "net model nominal from the next plan" in node.output, 5), node.output
    assert ask(crescent, 3).code == PlannerStatus.SUCCESS, node.output   # the map's circle alone: open water
