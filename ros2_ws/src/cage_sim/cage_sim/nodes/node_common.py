"""Parameter plumbing shared by the nodes (duck-typed on rclpy's Node; no ROS import here).

The vehicle's facts (speed, yaw-rate limit, metres per decision, action scale) are read from the same
parameters by every node of the graph (one YAML file, ``/**`` wildcard: config/graph.yaml), so the
vehicle integrates, the simulator judges and the policy decides on the same decision clock.
"""
from __future__ import annotations

import math

from ..vehicle import VehicleParams

_DEFAULTS = VehicleParams()
VEHICLE_PARAMETERS = {
    "speed": _DEFAULTS.speed,
    "max_yaw_rate_deg": math.degrees(_DEFAULTS.max_yaw_rate),
    "step_length": _DEFAULTS.step_length,
    "max_turn_deg": math.degrees(_DEFAULTS.max_turn),
}


def declare_vehicle(node) -> VehicleParams:
    """Declare the vehicle parameters on ``node`` and build VehicleParams (ValueError if invalid)."""
    vals = {k: float(node.declare_parameter(k, v).value) for k, v in VEHICLE_PARAMETERS.items()}
    return VehicleParams(speed=vals["speed"], max_yaw_rate=math.radians(vals["max_yaw_rate_deg"]),
                         step_length=vals["step_length"], max_turn=math.radians(vals["max_turn_deg"]))


def decision_period_ns(vehicle: VehicleParams) -> int:
    return int(round(vehicle.decision_period * 1e9))


def declare(node, **defaults):
    """Declare several parameters at once and return their values in a dict."""
    return {k: node.declare_parameter(k, v).value for k, v in defaults.items()}


def check(name: str, value, ok: bool, want: str) -> None:
    """Refuse a parameter with one line naming it (``run_node`` turns the ValueError into exit 2)."""
    if not ok:
        raise ValueError(f"parameter {name}:={value!r} is invalid: must be {want}")
