"""Routes for offline missions from the same planner, with the same options, as the rrt_node.

The options come from the node's own parameter file (config/rrt.yaml), so the evaluator's missions
follow exactly the waypoints the graph's rrt_node would publish for the same start and goal.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from .known_map import KnownMap
from .options import NODE_PARAMETERS, PlannerOptions, options_from_parameters
from .planner import GlobalPlanner

SOURCE_CONFIG = Path(__file__).resolve().parents[1] / "config" / "rrt.yaml"


def node_config_path() -> Path:
    """rrt.yaml: the file named by ``CAGE_RRT_CONFIG`` (to evaluate another planner configuration
    offline, e.g. ``planner: optimal``), else the installed share directory's, else the source tree's."""
    override = os.environ.get("CAGE_RRT_CONFIG")
    if override:
        return Path(override)
    try:
        from ament_index_python.packages import get_package_share_directory
        installed = Path(get_package_share_directory("cage_global_rrt")) / "config" / "rrt.yaml"
        if installed.is_file():
            return installed
    except (ImportError, LookupError, ValueError):
        pass
    return SOURCE_CONFIG


def node_options(path: str | Path | None = None) -> PlannerOptions:
    """The planner options the rrt_node runs with (its YAML over its declared defaults)."""
    data = yaml.safe_load(Path(path or node_config_path()).read_text()) or {}
    params = dict(NODE_PARAMETERS)
    params.update((data.get("/**/rrt_node") or data.get("rrt_node") or {}).get("ros__parameters") or {})
    return options_from_parameters(params)


@dataclass
class RoutePlanner:
    """``waypoint_fn`` for cage_sim's envs: plans each scenario's route on its known map.

    A request that fails is counted (``failures``) and returns None, so the env falls back to the
    straight line and the evaluator can report how often that happened. ``net_model``: the net wall
    the routes keep off (``known_map.NET_MODELS``: the surveyed circle, or the wall the mean current
    pushes in).
    """

    options: PlannerOptions = field(default_factory=node_options)
    net_model: str = "nominal"
    failures: list[str] = field(default_factory=list)
    requests: int = 0

    def __call__(self, scenario) -> np.ndarray | None:
        self.requests += 1
        planner = GlobalPlanner(KnownMap.from_world(scenario.world.known_map(), self.net_model), self.options)
        res = planner.plan(scenario.start, scenario.goal)
        if not res.ok:
            self.failures.append(f"{scenario.name}: {res.status.name}: {res.message}")
            return None
        return res.waypoints
