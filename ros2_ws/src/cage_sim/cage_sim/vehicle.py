"""Vehicle models: the study's kinematic step, and the continuous-time model the vehicle node integrates.

The continuous model: constant forward speed ``v`` through the water, heading driven toward a
setpoint at no more than ``max_yaw_rate`` (turn at the limit until the heading is reached, then hold
it), plus a uniform water current that drifts the position. Its closed-form integral over any
interval is exact, so integrating it in steps of any ``dt`` (the vehicle node) gives the same pose as
one step over a whole decision (the env). With the defaults (1 m/s, 20 deg/s, 1 m per decision)
the largest action turns at the limit for the whole decision: a turning radius of 2.86 m, the
study's "about 2.9 m".

A current that varies in space or time (current.py) has no closed form: ``advance`` integrates it in
substeps of at most ``MAX_SUBSTEP`` s (the current sampled at each substep's start), and falls back to
the exact closed form when the field is uniform. ``advance`` is THE motion function: the env's decision
step and the vehicle node's tick both call it, so they keep agreeing. ``velocity_over_ground`` is what a
DVL reports (body frame): through-water velocity plus the current, so drift is observable.

The study's step (turn instantly by the action, then move 1 m straight) is kept for reproducing its
results (``motion="study"`` in the env).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .current import CurrentField

MAX_SUBSTEP = 0.1   # s: substep for a varying current (0.1 m of travel at 1 m/s)


def wrap_angle(a):
    """Wrap angle(s) to [-pi, pi)."""
    return (np.asarray(a) + math.pi) % (2.0 * math.pi) - math.pi if isinstance(a, np.ndarray) \
        else (a + math.pi) % (2.0 * math.pi) - math.pi


@dataclass(frozen=True)
class VehicleParams:
    """One source of truth for the vehicle: speed, yaw-rate limit, decision length, action scale."""

    speed: float = 1.0                         # m/s through the water
    max_yaw_rate: float = math.radians(20.0)   # rad/s
    step_length: float = 1.0                   # m travelled per decision
    max_turn: float = math.radians(20.0)       # rad: |change of heading| per decision (action = +-1)

    def __post_init__(self) -> None:
        for name in ("speed", "max_yaw_rate", "step_length", "max_turn"):
            v = getattr(self, name)
            if not (v > 0 and math.isfinite(v)):
                raise ValueError(f"vehicle {name} must be a positive number, got {v!r}")

    @property
    def decision_period(self) -> float:
        """Seconds per decision: the time to travel ``step_length`` at ``speed``."""
        return self.step_length / self.speed

    @property
    def turning_radius(self) -> float:
        return self.speed / self.max_yaw_rate

    def heading_change(self, action):
        """Action in [-1, 1] -> change of heading (rad), clipped to the limit. A float stays a float
        (``np.clip`` of one number costs ~10 us, paid at every decision of every rollout)."""
        if isinstance(action, float) and action == action:   # not NaN: NaN stays NaN through np.clip
            return max(-1.0, min(1.0, action)) * self.max_turn
        return np.clip(action, -1.0, 1.0) * self.max_turn


def study_step(x, y, yaw, dpsi, step_length: float = 1.0, max_turn: float = math.radians(20.0)):
    """The study's kinematic step: heading += clip(dpsi); then move ``step_length`` along it."""
    yaw = yaw + np.clip(dpsi, -max_turn, max_turn)
    return x + step_length * np.cos(yaw), y + step_length * np.sin(yaw), yaw


def propagate(x, y, yaw, heading_setpoint, dt, speed: float = 1.0,
              max_yaw_rate: float = math.radians(20.0), current=(0.0, 0.0)):
    """Exact integral of the continuous model over ``dt`` seconds (scalars or arrays).

    Turn toward ``heading_setpoint`` at ``max_yaw_rate`` until it is reached (then straight), moving
    at ``speed`` along the heading, plus the current's drift ``current * dt``.
    """
    if isinstance(x, float) and isinstance(y, float) and isinstance(yaw, float) \
            and isinstance(heading_setpoint, float) and isinstance(dt, float):     # one pose: plain math, ~10x faster
        x1, y1, yaw1 = _propagate_scalar(x, y, yaw, heading_setpoint, dt, speed, max_yaw_rate,
                                         (float(current[0]), float(current[1])))
        return float(x1), float(y1), float(wrap_angle(yaw1))
    err = wrap_angle(np.asarray(heading_setpoint, dtype=float) - yaw)
    t_turn = np.minimum(np.abs(err) / max_yaw_rate, dt)
    rate = np.sign(err) * max_yaw_rate
    yaw1 = yaw + rate * t_turn
    turning = np.abs(rate * t_turn) > 1e-12
    safe_rate = np.where(turning, rate, 1.0)
    # Arc while turning (exact), chord limit when not turning.
    ax = np.where(turning, speed / safe_rate * (np.sin(yaw1) - np.sin(yaw)), speed * t_turn * np.cos(yaw))
    ay = np.where(turning, -speed / safe_rate * (np.cos(yaw1) - np.cos(yaw)), speed * t_turn * np.sin(yaw))
    straight = speed * (dt - t_turn)
    x1 = x + ax + straight * np.cos(yaw1) + current[0] * dt
    y1 = y + ay + straight * np.sin(yaw1) + current[1] * dt
    if np.ndim(x1) == 0:
        return float(x1), float(y1), float(wrap_angle(float(yaw1)))
    return x1, y1, wrap_angle(yaw1)


def advance(x: float, y: float, yaw: float, heading_setpoint: float, dt: float, params: VehicleParams,
            current: "CurrentField | tuple[float, float]" = (0.0, 0.0), t: float = 0.0,
            speed: float | None = None) -> tuple[float, float, float]:
    """Pose after ``dt`` s flying toward ``heading_setpoint`` in ``current`` (a field or a uniform vector)
    starting at time ``t``: exact for a uniform current, substeps of <= MAX_SUBSTEP s otherwise.
    ``speed``: through-water speed if not ``params.speed`` (a slower setpoint; 0 drifts with the water)."""
    v = params.speed if speed is None else speed
    if not isinstance(current, CurrentField):
        return propagate(x, y, yaw, heading_setpoint, dt, v, params.max_yaw_rate, current)
    if current.is_uniform:
        return propagate(x, y, yaw, heading_setpoint, dt, v, params.max_yaw_rate, current.uniform)
    n = max(1, int(math.ceil(dt / MAX_SUBSTEP - 1e-9)))
    h = dt / n
    for i in range(n):
        c = current.velocity(x, y, t + i * h)
        x, y, yaw = _propagate_scalar(x, y, yaw, heading_setpoint, h, v, params.max_yaw_rate, c)
    return x, y, wrap_angle(yaw)


def _propagate_scalar(x: float, y: float, yaw: float, sp: float, dt: float, speed: float, rate_max: float,
                      c: tuple[float, float]) -> tuple[float, float, float]:
    """``propagate`` for floats in plain ``math`` (the substep loop; ~10x less overhead than NumPy)."""
    err = (sp - yaw + math.pi) % (2.0 * math.pi) - math.pi
    t_turn = min(abs(err) / rate_max, dt)
    rate = math.copysign(rate_max, err) if err != 0.0 else 0.0
    yaw1 = yaw + rate * t_turn
    if abs(rate * t_turn) > 1e-12:
        ax = speed / rate * (math.sin(yaw1) - math.sin(yaw))
        ay = -speed / rate * (math.cos(yaw1) - math.cos(yaw))
    else:
        ax, ay = speed * t_turn * math.cos(yaw), speed * t_turn * math.sin(yaw)
    straight = speed * (dt - t_turn)
    return (x + ax + straight * math.cos(yaw1) + c[0] * dt, y + ay + straight * math.sin(yaw1) + c[1] * dt, yaw1)


def velocity_over_ground(yaw: float, speed: float, current: tuple[float, float]) -> tuple[float, float]:
    """Body-frame (forward, left) velocity over ground, as a DVL reports: ``speed`` through the water
    along the heading plus the water's own velocity ``current`` (map frame) at the vehicle."""
    c, s = math.cos(yaw), math.sin(yaw)
    return speed + current[0] * c + current[1] * s, -current[0] * s + current[1] * c


def decision_step(x, y, yaw, action, params: VehicleParams, current=(0.0, 0.0), motion: str = "continuous",
                  t: float = 0.0):
    """Advance one decision from an action in [-1, 1], in either motion mode.

    ``continuous``: the heading setpoint ``yaw + action * max_turn`` integrated over one decision
    period by ``advance`` (what the vehicle node does): ``current`` a uniform vector or a
    ``CurrentField`` (then ``t`` is the decision's start time). ``study``: the study's instantaneous
    step (no current: the study had none).
    """
    dpsi = params.heading_change(action)
    if motion == "study":
        x1, y1, yaw1 = study_step(x, y, yaw, dpsi, params.step_length, params.max_turn)
        return x1, y1, wrap_angle(yaw1)
    if motion != "continuous":
        raise ValueError(f"motion must be 'continuous' or 'study', got {motion!r}")
    return advance(x, y, yaw, yaw + dpsi, params.decision_period, params, current, t)
