"""Global planner for the sea cage: OMPL planning over the known map (ROS-free core) plus the
ROS 2 node ``rrt_node`` that adapts it to topics."""
from .known_map import KnownMap
from .lower_bound import VisibilityGraph, shortest_path_lower_bound
from .options import PLANNERS, PlannerOptions
from .planner import GlobalPlanner, PlanResult, plan
from .status import PlanStatus

__all__ = ["KnownMap", "VisibilityGraph", "shortest_path_lower_bound", "PLANNERS", "PlannerOptions",
           "GlobalPlanner", "PlanResult", "plan", "PlanStatus"]
