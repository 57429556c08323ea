"""Inevitable collision states: a pose from which no manoeuvre of the vehicle keeps off the world.

Why: the scenario generators placed starts 2.5 m from any obstacle with a heading up to 90 deg off
the goal's. In calm water that always leaves a way out, but a 0.5 m/s current that pushes a vehicle
pointed at an obstacle 2.8 m away closes it in two decisions whatever it does (measured: 4 of the 6
shielded collisions of 1000 missions at 0.5 m/s were at decision 2 or 3, and none of 625 sequences
of four actions escaped them). A mission that starts in a collision no driver can avoid measures
the generator, not the driver; a real vehicle starts from station keeping, not mid-approach.

``escapable`` asks the question exactly, for a discretised vehicle, with the true world, the
true current and the vehicle model (``decision_step``, continuous motion): does some sequence of
``decisions`` actions from ``ACTIONS`` keep the safety radius at every decision's midpoint and end
(as ``Mission.record`` judges)? Only a start no sequence survives is rejected: one that some driver
might still escape stays (a longer horizon or a family of manoeuvres rejected starts the shielded
policy did escape). Pure, deterministic, no random draws, so a generator that uses it draws the
same accepted scenarios as before.
"""
from __future__ import annotations

from .vehicle import VehicleParams, decision_step
from .world import World

ACTIONS = (0.0, -1.0, 1.0, -0.5, 0.5)   # straight first: most starts pass with it
DECISIONS = 4                            # decisions looked ahead: 5**4 = 625 sequences at most


def step_clear(world: World, pose: tuple[float, float, float], action: float, t: float,
               vehicle: VehicleParams) -> tuple[float, float, float] | None:
    """The pose after one decision flown with ``action`` from ``pose`` at time ``t``, or None when
    its midpoint or end comes within the world's safety radius of anything."""
    x, y, yaw = pose
    period = vehicle.decision_period
    x1, y1, yaw1 = decision_step(x, y, yaw, action, vehicle, world.current_field, "continuous", t)
    if min(world.clearance(x1, y1, t + period),
           world.clearance(0.5 * (x + x1), 0.5 * (y + y1), t + 0.5 * period)) < world.safety_radius:
        return None
    return x1, y1, yaw1


def escapable(world: World, pose: tuple[float, float, float], decisions: int = DECISIONS,
              vehicle: VehicleParams | None = None, t: float = 0.0) -> bool:
    """Whether some sequence of ``decisions`` actions from ``ACTIONS`` keeps off the world (depth
    first: stops at the first that does)."""
    if decisions <= 0:
        return True
    v = vehicle or VehicleParams()
    for a in ACTIONS:
        nxt = step_clear(world, pose, a, t, v)
        if nxt is not None and escapable(world, nxt, decisions - 1, v, t + v.decision_period):
            return True
    return False
