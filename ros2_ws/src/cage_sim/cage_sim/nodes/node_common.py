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


# Sensor overrides a launch may set on top of the profile; -1 (the default) = the profile's own value.
SENSOR_OVERRIDES = {"n_beams": -1, "max_range": -1.0, "beam_width_deg": -1.0, "noise_std": -1.0, "dropout": -1.0,
                    "clutter": -1.0}


def declare_sensor(node, default: str = "study"):
    """Declare ``sensor`` (a profile name of ``cage_sim.sonar``) and its overrides; the SonarModel.

    One line naming the parameter for an unknown profile or a bad override (exit 2), as ``check``."""
    from ..sonar import PROFILE_NAMES, SonarConfigError, make_sonar
    p = declare(node, sensor=default, **SENSOR_OVERRIDES)
    check("sensor", p["sensor"], p["sensor"] in PROFILE_NAMES, f"one of {', '.join(PROFILE_NAMES)}")
    n = p["n_beams"]
    check("n_beams", n, isinstance(n, int) and not isinstance(n, bool) and (n == -1 or 1 <= n <= 4096),
          "in [1, 4096] (-1: the profile's)")
    given = {"n_beams": n} if n != -1 else {}
    for k in ("max_range", "beam_width_deg", "noise_std", "dropout", "clutter"):
        v = p[k]
        check(k, v, isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
              and (v == -1 or v >= 0), ">= 0 (-1: the profile's)")
        if v != -1:
            given[k] = float(v)
    try:
        return make_sonar(p["sensor"], **given)
    except SonarConfigError as err:
        name = str(err).split(":", 1)[0].removeprefix("sonar.")
        name = {"beam_width": "beam_width_deg"}.get(name, name)      # the model's field -> the parameter
        raise ValueError(f"parameter {name}:={given.get(name, p['sensor'])!r} is invalid: {str(err).split(':', 1)[-1].strip()}") from None


def start_only_reason(name: str) -> str:
    """Why ``ros2 param set`` of ``name`` is refused by a node that reads it at start only (the
    nodes answer with this reason rather than keep a value they no longer act on)."""
    return f"{name} is read at start only: restart the node to change it"
