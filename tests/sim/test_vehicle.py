"""Vehicle models against hand-computed steps."""
import math

import numpy as np
import pytest

from cage_sim.vehicle import VehicleParams, decision_step, propagate, study_step, wrap_angle


def test_study_step_function_check():
    # The study's check: actions [20, -5, -15] deg from the origin heading 0, L = 1 m.
    x = y = yaw = 0.0
    expected_yaw = [20.0, 15.0, 0.0]
    xs = ys = 0.0
    for a, e in zip([20.0, -5.0, -15.0], expected_yaw):
        x, y, yaw = study_step(x, y, yaw, math.radians(a))
        xs += math.cos(math.radians(e))
        ys += math.sin(math.radians(e))
        assert math.degrees(yaw) == pytest.approx(e)
        assert (x, y) == pytest.approx((xs, ys))
    assert (x, y) == pytest.approx((0.9397 + 0.9659 + 1.0, 0.3420 + 0.2588 + 0.0), abs=1e-4)


def test_study_step_clips_turn():
    _, _, yaw = study_step(0.0, 0.0, 0.0, math.radians(45))
    assert math.degrees(yaw) == pytest.approx(20.0)


def test_continuous_full_turn_is_an_arc_of_the_turning_radius():
    p = VehicleParams()
    assert p.turning_radius == pytest.approx(2.8648, abs=1e-4)
    x, y, yaw = decision_step(0.0, 0.0, 0.0, 1.0, p)
    R, th = p.turning_radius, math.radians(20)
    assert (x, y) == pytest.approx((R * math.sin(th), R * (1 - math.cos(th))))
    assert yaw == pytest.approx(th)


def test_continuous_partial_turn_then_straight():
    # 10 deg at 20 deg/s: 0.5 s of arc, then 0.5 m straight.
    x, y, yaw = propagate(0.0, 0.0, 0.0, math.radians(10), 1.0)
    R, th = 1.0 / math.radians(20), math.radians(10)
    ex = R * math.sin(th) + 0.5 * math.cos(th)
    ey = R * (1 - math.cos(th)) + 0.5 * math.sin(th)
    assert (x, y, yaw) == pytest.approx((ex, ey, th))


@pytest.mark.parametrize("dt", [0.5, 0.1, 0.013, 0.25])
def test_integration_in_small_steps_equals_one_decision(dt):
    """What the vehicle node integrates equals what the env steps, whatever the node's dt."""
    current = (0.07, -0.03)
    sp = 0.4 + math.radians(-17)
    one = propagate(1.0, 2.0, 0.4, sp, 1.0, current=current)
    x, y, yaw = 1.0, 2.0, 0.4
    n = int(round(1.0 / dt))
    for _ in range(n):
        x, y, yaw = propagate(x, y, yaw, sp, 1.0 / n, current=current)
    assert (x, y, yaw) == pytest.approx(one, abs=1e-9)


@pytest.mark.parametrize("current", [(0.0, 0.0), (0.3, -0.2)])
def test_vectorised_propagate_matches_scalar(current):
    """The array path (NumPy) and the one-pose path (plain math) are two codes for one model."""
    rng = np.random.default_rng(0)
    x, y, yaw, sp = (rng.uniform(-3, 3, 50) for _ in range(4))
    sp[:5] = yaw[:5]                                  # already on the setpoint: straight
    vx, vy, vyaw = propagate(x, y, yaw, sp, 0.7, current=current)
    for i in range(50):
        one = propagate(float(x[i]), float(y[i]), float(yaw[i]), float(sp[i]), 0.7, current=current)
        assert all(type(v) is float for v in one)
        assert (vx[i], vy[i], vyaw[i]) == pytest.approx(one, abs=1e-12)


def test_heading_change_of_a_float_equals_the_array_rule():
    p = VehicleParams()
    acts = [-3.0, -1.0, -0.37, 0.0, 0.5, 1.0, 2.5]
    assert [p.heading_change(a) for a in acts] == pytest.approx(list(p.heading_change(np.array(acts))), abs=0)
    assert math.isnan(p.heading_change(float("nan")))


def test_wrap_angle():
    assert wrap_angle(3 * math.pi / 2) == pytest.approx(-math.pi / 2)
    assert np.allclose(wrap_angle(np.array([0.0, 2 * math.pi + 0.1])), [0.0, 0.1])


def test_bad_params_rejected():
    with pytest.raises(ValueError, match="speed"):
        VehicleParams(speed=0.0)
    with pytest.raises(ValueError, match="motion"):
        decision_step(0, 0, 0, 0.5, VehicleParams(), motion="teleport")
