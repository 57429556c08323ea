"""The pure fault-handling pieces: scan validation, route recovery after a restart, silence watch."""
from __future__ import annotations

import math

import numpy as np
import pytest

from cage_sim.recovery import joining_under_way, remaining_route
from cage_sim.scan_check import ScanSpec, scan_problem
from cage_sim.sonar import SonarModel
from cage_sim.watchdog import Silence

SPEC = ScanSpec.from_sonar(SonarModel(n_beams=72, angle_increment=2 * math.pi / 72), "base_link", 0.25)
GOOD = np.full(72, 10.0)


def test_a_good_scan_passes_and_inf_means_no_return():
    assert scan_problem(SPEC, "base_link", 0.0, 2 * math.pi / 72, GOOD) is None
    assert scan_problem(SPEC, "base_link", 0.0, 2 * math.pi / 72, np.full(72, np.inf)) is None
    assert scan_problem(SPEC, "base_link", 2 * math.pi, 2 * math.pi / 72, GOOD) is None  # same angle


@pytest.mark.parametrize("frame, amin, inc, ranges, words", [
    ("sonar_link", 0.0, 2 * math.pi / 72, GOOD, "frame"),
    ("", 0.0, 2 * math.pi / 72, GOOD, "frame"),
    ("base_link", math.pi, 2 * math.pi / 72, GOOD, "rotated"),          # a scan rotated by 180 deg
    ("base_link", float("nan"), 2 * math.pi / 72, GOOD, "angle_min"),
    ("base_link", 0.0, -2 * math.pi / 72, GOOD, "angle_increment"),      # beams in the other direction
    ("base_link", 0.0, math.radians(2.5), GOOD, "angle_increment"),
    ("base_link", 0.0, float("inf"), GOOD, "angle_increment"),
    ("base_link", 0.0, 2 * math.pi / 72, np.full(71, 10.0), "71 ranges"),
    ("base_link", 0.0, 2 * math.pi / 72, np.full(100_000, 10.0), "100000 ranges"),
    ("base_link", 0.0, 2 * math.pi / 72, [], "0 ranges"),
    ("base_link", 0.0, 2 * math.pi / 72, np.full(72, np.nan), "invalid"),
    ("base_link", 0.0, 2 * math.pi / 72, np.full(72, -1.0), "invalid"),
])
def test_unusable_scans_are_refused_with_the_reason(frame, amin, inc, ranges, words):
    problem = scan_problem(SPEC, frame, amin, inc, ranges)
    assert problem is not None and words in problem and "\n" not in problem


def test_a_few_missing_ranges_are_tolerated_up_to_the_fraction():
    r = GOOD.copy()
    r[:18] = np.nan      # exactly 25 %
    assert scan_problem(SPEC, "base_link", 0.0, 2 * math.pi / 72, r) is None
    r[18] = -3.0
    assert "19 of 72" in scan_problem(SPEC, "base_link", 0.0, 2 * math.pi / 72, r)


ROUTE = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])


def test_a_restarted_node_does_not_fly_back_to_the_mission_start():
    assert remaining_route(ROUTE, (9.0, 4.0)).tolist() == [[10.0, 10.0], [0.0, 10.0]]
    assert remaining_route(ROUTE, (4.0, 0.5)).tolist() == [[10.0, 0.0], [10.0, 10.0], [0.0, 10.0]]
    assert remaining_route(ROUTE, (1.0, 11.0)).tolist() == [[0.0, 10.0]]      # the goal is always kept
    assert remaining_route(ROUTE[-1:], (50.0, 50.0)).tolist() == [[0.0, 10.0]]


def test_before_the_first_waypoint_nothing_is_dropped():
    assert remaining_route(ROUTE, (-5.0, -1.0)).tolist() == ROUTE.tolist()


def test_only_a_node_that_joins_its_first_mission_late_is_joining_under_way():
    assert joining_under_way(True, 37_000_000_000)
    assert not joining_under_way(True, 0)          # a fresh graph: the mission starts with the clock
    assert not joining_under_way(False, 37_000_000_000)   # goal after goal in a running graph


def test_silence_is_said_once_and_the_return_once():
    s = Silence(1.0)
    assert s.check(100.0) is None             # never heard: not started, not silent
    s.heard(0.0)
    assert s.check(0.5) is None
    assert s.check(1.5) == pytest.approx(1.5)
    assert s.check(9.0) is None               # once
    assert s.heard(9.5) is True and s.heard(9.6) is False
    with pytest.raises(ValueError):
        Silence(0.0)
