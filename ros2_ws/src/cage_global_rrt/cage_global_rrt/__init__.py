"""Global planner for the sea cage: OMPL planning or the shortest path (visibility graph) over the
known map, flyable corners, an obstacle layer learnt from the sonar (ROS-free core), plus the ROS 2
node ``rrt_node`` that adapts it to topics."""
from .known_map import KnownMap
from .lower_bound import VisibilityGraph, shortest_path_lower_bound
from .options import PLANNERS, PlannerOptions
from .planner import GlobalPlanner, PlanResult, plan
from .status import PlanStatus
from .visibility import OptimalGraph, optimal_graph
from .obstacle_layer import LayerParams, ObstacleLayer, plan_with_layer

__all__ = ["KnownMap", "VisibilityGraph", "shortest_path_lower_bound", "PLANNERS", "PlannerOptions",
           "GlobalPlanner", "PlanResult", "plan", "PlanStatus", "OptimalGraph", "optimal_graph",
           "LayerParams", "ObstacleLayer", "plan_with_layer"]
