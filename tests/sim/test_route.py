"""Route progress and the replan triggers policy_node acts on (pure code, no middleware)."""
from __future__ import annotations

import math

import pytest

from cage_sim.map_points import MapPoints
from cage_sim.route import GOAL_IN_SIGHT, ReplanWatch, RouteTracker, StallWatch
from cage_sim.world import Obstacle, World


def tracker() -> RouteTracker:
    return RouteTracker((0.0, 0.0), [(0.0, 30.0), (20.0, 30.0)])       # north 30 m, then east 20 m


def test_waypoints_advance_when_reached_or_passed():
    t = tracker()
    assert not t.advance(0.0, 10.0) and t.index == 0
    assert t.advance(3.0, 31.0) and t.index == 1                        # passed the first one
    assert t.remaining(10.0, 30.0) == pytest.approx(10.0)
    assert t.segment_offset(10.0, 34.0) == pytest.approx(4.0)


def test_a_later_waypoint_within_reach_is_flown_on_from():
    t = RouteTracker((0.0, 0.0), [(0.0, 30.0), (10.0, 30.0), (20.0, 30.0)])
    assert t.advance(19.0, 29.0) and t.at_last            # came to the goal round the first two
    assert t.remaining(19.0, 29.0) == pytest.approx(2 ** 0.5)
    t = RouteTracker((0.0, 0.0), [(0.0, 30.0), (10.0, 30.0), (20.0, 30.0)])
    assert t.advance(9.0, 28.5) and t.index == 2          # at the middle one: past it, on to the goal
    assert t.segment_offset(15.0, 30.0) == pytest.approx(0.0)
    assert not t.advance(10.0, 20.0) and t.index == 2     # never back to an earlier one
    t = RouteTracker((0.0, 0.0), [(0.0, 30.0), (10.0, 30.0), (20.0, 30.0)])
    assert not t.advance(18.5, 27.0) and t.index == 0     # 3.4 m from the goal: not within reach (2 m)


def test_a_goal_in_sight_is_flown_to_straight():
    # A corner at (0, 20), the goal 6 m east of it. Pushed off the route to (4, 15), the vehicle is
    # nearer the goal (5.4 m) than the corner (6.4 m): with the known map clear on the way it flies
    # straight to the goal; without a map, or with a known square on the way, it keeps the corner.
    route, off = [(0.0, 20.0), (6.0, 20.0)], (4.0, 15.0)
    clear = MapPoints.from_world(World(30.0))
    blocked = MapPoints.from_world(World(30.0, (Obstacle("square", 5.0, 17.5, 1.0),)))
    assert not RouteTracker((0.0, 0.0), route).advance(*off)                       # no map: the corner
    assert not RouteTracker((0.0, 0.0), route, known=blocked).advance(*off)        # the way is not clear
    t = RouteTracker((0.0, 0.0), route, known=clear)
    assert t.advance(*off) and t.at_last
    assert t.remaining(*off) == pytest.approx(29 ** 0.5)
    assert t.segment_offset(5.0, 17.5) == pytest.approx(0.0)                       # judged from here on
    t = RouteTracker((0.0, 0.0), route, known=clear)
    assert not t.advance(1.0, 17.0) and t.index == 0                               # the corner is nearer
    far = RouteTracker((0.0, 0.0), [(0.0, 20.0), (12.0, 20.0)], known=clear)
    assert math.dist((9.0, 9.0), (12.0, 20.0)) > GOAL_IN_SIGHT
    assert not far.advance(9.0, 9.0) and far.index == 0                            # nearer, but too far
    t = RouteTracker((0.0, 0.0), route)
    t.known = clear                                                                 # a map that came later
    assert t.advance(*off) and t.at_last


def test_following_the_route_asks_for_nothing():
    t, w = tracker(), ReplanWatch(after=10, min_progress=2.0, max_offset=8.0)
    for k in range(51):                                                 # to the goal at (20, 30)
        x, y = (0.0, float(k)) if k <= 30 else (float(k - 30), 30.0)
        t.advance(x, y)
        assert w.update(t, x, y) is None, k


def test_no_progress_asks_after_n_decisions_and_again_n_later():
    t, w = tracker(), ReplanWatch(after=5, min_progress=2.0)
    asked = [k for k in range(20) if w.update(t, 0.5, 10.0) is not None]   # standing still
    assert asked == [5, 10, 15]                                          # 0 counts as progress (from inf)


def test_off_the_route_asks_once_then_rests_until_a_new_route():
    t, w = tracker(), ReplanWatch(after=10, min_progress=2.0, max_offset=8.0)
    reasons = []
    for k in range(12):                                                 # heading east, away from the segment
        x, y = float(k), float(k)
        reasons.append(w.update(t, x, y))
    assert [k for k, r in enumerate(reasons) if r] == [9] and "9.0 m off the route" in reasons[9]
    assert all(w.update(t, 12.0 + k, 12.0) is None for k in range(3))   # resting: the planner was asked
    w.reset()                                                           # a new route came (still off this one)
    assert "off the route" in (w.update(t, 15.0, 12.0) or "")


def test_off_route_trigger_is_off_at_zero():
    t, w = tracker(), ReplanWatch(after=100, min_progress=2.0, max_offset=0.0)
    assert all(w.update(t, float(k), float(k)) is None for k in range(1, 25))


def test_stall_watch_hands_over_after_no_progress_and_back_after_gain():
    w = StallWatch(after=5, min_progress=1.0, hold=30, gain=5.0)
    assert not any(w.update(50.0 - 1.5 * k) for k in range(20))      # 1.5 m of progress per decision
    flags = [w.update(21.5) for _ in range(5)]                        # stuck at 21.5 m left
    assert flags == [False] * 4 + [True]
    assert all(w.update(r) for r in (21.0, 19.0, 17.0, 16.5))          # flown until under 16.5 m (21.5 - 5)
    assert not w.update(15.5)                                         # 5.5 m further: the policy again
    assert not any(w.update(15.5) for _ in range(4)) and w.update(15.5)   # a fresh count of 5


def test_stall_watch_gives_back_after_hold_and_restarts_on_a_new_route():
    w = StallWatch(after=3, min_progress=1.0, hold=4, gain=5.0)
    assert [w.update(10.0) for _ in range(4)] == [False, False, False, True]
    assert [w.update(10.0) for _ in range(4)] == [True, True, True, False]   # hold spent, no gain
    w = StallWatch(after=3, min_progress=1.0, jump=2.0)
    assert [w.update(10.0) for _ in range(3)] == [False, False, False]
    assert not w.update(25.0)                         # a replan: 15 m more route, the count starts again
    assert [w.update(25.0) for _ in range(3)] == [False, False, True]
    assert not w.update(float("nan"))                 # no route known: never takes over
    w = StallWatch(after=3, min_progress=1.0, hold=10, gain=5.0)
    assert [w.update(10.0) for _ in range(4)] == [False, False, False, True]
    assert w.update(30.0) and w.update(27.0)          # replanned while the controller flies: it goes on
    assert not w.update(24.5)                         # 5.5 m along the new route: the policy again


@pytest.mark.parametrize("kw", [{"after": 0}, {"hold": 0}, {"gain": 0.0}, {"min_progress": -1.0}, {"jump": 0.0}])
def test_stall_watch_refuses_bad_parameters(kw):
    with pytest.raises(ValueError, match="stall watch"):
        StallWatch(**kw)
