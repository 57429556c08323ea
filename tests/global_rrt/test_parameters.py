"""The node's parameters (ROS-free part): defaults, the shipped YAML, and clear errors."""
from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from cage_global_rrt.options import (NODE_PARAMETERS, InvalidParameters, PlannerOptions,
                                     options_from_parameters)

CONFIG = Path(__file__).resolve().parents[2] / "ros2_ws/src/cage_global_rrt/config/rrt.yaml"


def test_defaults_are_the_library_defaults_but_seeded_with_corner_waypoints():
    # the node publishes corners (what the graph flies, as rrt.yaml says) and plans reproducibly
    assert options_from_parameters(dict(NODE_PARAMETERS)) == PlannerOptions(seed=1, waypoint_spacing=0.0)


def test_shipped_yaml_is_valid_and_complete():
    params = yaml.safe_load(CONFIG.read_text())["/**/rrt_node"]["ros__parameters"]
    assert set(params) == set(NODE_PARAMETERS)
    assert params == NODE_PARAMETERS      # the node's declared defaults are the shipped file's values
    for name, value in params.items():
        assert type(value) is type(NODE_PARAMETERS[name]), name
    opts = options_from_parameters(params)
    assert opts.seed == 1 and opts.planner == "rrt"


@pytest.mark.parametrize("change,word", [(dict(planner="astar"), "planner"), (dict(max_step=-1.0), "max_step"),
                                         (dict(planner_seed=-5), "seed"), (dict(typo=1), "typo"),
                                         (dict(time_limit=0.0), "time_limit")])
def test_bad_parameter_is_named(change, word):
    with pytest.raises(InvalidParameters, match=word):
        options_from_parameters({**NODE_PARAMETERS, **change})


def test_seed_parameter():
    assert options_from_parameters({**NODE_PARAMETERS, "planner_seed": 9}).seed == 9
    assert options_from_parameters({**NODE_PARAMETERS, "planner_seed": 0}).seed is None
