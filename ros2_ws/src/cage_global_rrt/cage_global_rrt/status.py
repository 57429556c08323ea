"""Outcome codes of one planning request.

The numbers are those of ``cage_planner_msgs/msg/PlannerStatus.msg`` (named like Nav2's
ComputePathToPose error codes), so the node can copy ``int(status)`` straight into the message and
the core stays importable without ROS.
"""
from __future__ import annotations

from enum import IntEnum


class PlanStatus(IntEnum):
    SUCCESS = 0
    START_OCCUPIED = 1
    START_OUTSIDE_NET = 2
    GOAL_OCCUPIED = 3
    GOAL_OUTSIDE_NET = 4
    TIMEOUT = 5
    NO_VALID_PATH = 6
    NO_MAP = 7
    NO_POSE = 8
    INVALID_INPUT = 9
