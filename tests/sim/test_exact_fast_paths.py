"""The decision's fast paths give the very bits of the plain computation they replace.

Why bit for bit: the published matrices, the graph-equals-offline tests and the shipped policy's
figures were all made with the plain code; a faster decision that differed in the last bit could
fly another mission. Each fast path is checked against the plain computation on random inputs
and on scans of moving schools.
"""
import math

import numpy as np

from cage_sim.controller import ArcController, _min_squared_near, nearest_distance
from cage_sim.perception import (Perception, ReturnMotion, _cluster_medians, _point_segment_distance,
                                 to_body, to_map)
from cage_sim.shield import CHUNK, Commitment, SafetyShield
from cage_sim.sonar import SonarModel
from cage_sim.world import Obstacle, World


def random_returns(rng, k: int, moving: float) -> tuple[np.ndarray, np.ndarray]:
    """K returns 0-13 m around the vehicle, in clumps as a sonar sees walls and fish, and each
    one's relative velocity: the drift for most, the drift minus a fish's speed for ``moving``."""
    centres = rng.uniform(-13, 13, (max(1, k // 8), 2))
    pts = centres[rng.integers(0, len(centres), k)] + rng.normal(0, 0.6, (k, 2))
    drift = rng.uniform(-0.5, 0.5, 2)
    rel = np.repeat(drift[None], k, axis=0)
    fish = rng.random(k) < moving
    rel[fish] -= rng.uniform(-0.8, 0.8, (int(fish.sum()), 2))
    return pts, rel


def test_clearance_below_cap_is_nearest_distance_bit_for_bit():
    ctrl = ArcController()
    pts_, t_ = ctrl._distinct.points, ctrl._distinct.times
    rng = np.random.default_rng(11)
    kept = 0
    for case in range(150):
        q, rel = random_returns(rng, int(rng.integers(1, 160)), moving=(0.0, 0.1, 0.5)[case % 3])
        cap = float(rng.choice([1.1, 2.5, 4.0]))
        want = nearest_distance(pts_, t_, rel, q)
        got = np.sqrt(_min_squared_near(pts_, t_, ctrl._distinct.blocks, rel, q, cap))
        below = want < cap
        assert np.array_equal(got[below], want[below])        # exact where it counts
        assert np.all(got[~below] >= cap)                     # elsewhere at least the cap
        kept += int(below.sum())
    assert kept > 1000                                        # the cases really came near


class PlainController(ArcController):
    """The controller with the clearance of every (point, return) pair: the reference."""

    def _clearance_below(self, cap, rel, pts):
        return nearest_distance(self._distinct.points, self._distinct.times, rel, pts)


def test_controller_decides_as_with_every_pair():
    fast, plain = ArcController(), PlainController()
    rng = np.random.default_rng(5)
    actions = set()
    for case in range(400):
        q, rel = random_returns(rng, int(rng.integers(0, 140)), moving=(0.0, 0.2)[case % 2])
        drift = rel[0] if len(rel) else rng.uniform(-0.5, 0.5, 2)
        p = Perception(q, drift[None] - rel if len(q) else None, drift, bool(case % 3 == 0))
        dist, err = float(rng.uniform(0.5, 20)), float(rng.uniform(-math.pi, math.pi))
        a = fast.decide(dist, err, p)
        assert a == plain.decide(dist, err, p), case
        actions.add(round(a, 3))
    assert len(actions) > 10                                  # turns of every kind were chosen


def test_capped_horizon_margins_are_exact_below_the_cap():
    # The boxed-in choice measures its margins capped at min_clearance (session 46): each distinct
    # continuation point only against the returns near its block. Below the cap the margins must be
    # the plain ones bit for bit, at or above it they must stay there.
    shield = SafetyShield(lambda obs: np.zeros(1))
    rng = np.random.default_rng(46)
    firsts = np.linspace(-1.0, 1.0, 21)
    kept = capped = 0
    for case in range(60):
        q, rel = random_returns(rng, int(rng.integers(1, 200)), moving=(0.0, 0.3)[case % 2])
        q *= 0.5                                                    # near: margins on both sides of the cap
        drift = rel[0]
        goal = rng.uniform(-8, 8, 2) if case % 3 == 0 else None
        h, s_turns = int(rng.choice([5, 7, 10])), bool(case % 2)
        cap = float(rng.choice([1.0, 1.5]))
        want = shield.horizon_margins(firsts, q, rel, goal, drift, h, s_turns)
        got = shield.horizon_margins(firsts, q, rel, goal, drift, h, s_turns, cap=cap)
        below = want < cap
        assert np.array_equal(got[below], want[below]), case
        assert np.all(got[~below] >= cap), case
        kept += int(below.sum())
        capped += int((~below).sum())
    assert kept > 500 and capped > 500                               # both sides were tested


class PlainShield(SafetyShield):
    """The shield with every margin measured against every return (the code before session 46):
    the reference."""

    def horizon_margins(self, *args, cap=None, **kw):
        return super().horizon_margins(*args, **kw)

    def _margin_at(self, a, look, floor=-math.inf, capped=True):
        return super()._margin_at(a, look, floor, capped=False)


def test_shield_boxed_in_choice_as_with_every_pair():
    fast, plain = SafetyShield(lambda obs: np.zeros(1)), PlainShield(lambda obs: np.zeros(1))
    calls, plans = [], set()
    inner = SafetyShield.horizon_margins

    def counted(self, *args, **kw):
        calls.append(kw.get("cap"))
        return inner(self, *args, **kw)
    rng = np.random.default_rng(7)
    SafetyShield.horizon_margins = counted
    try:
        for case in range(120):
            q, rel = random_returns(rng, int(rng.integers(20, 160)), moving=(0.0, 0.2)[case % 2])
            q *= 0.35                                               # crowded: often boxed in
            drift = rel[0]
            p = Perception(q, drift[None] - rel, drift, bool(case % 3 == 0))
            dist, err = float(rng.uniform(0.5, 20)), float(rng.uniform(-math.pi, math.pi))
            a = float(rng.uniform(-1, 1))
            mine, theirs = Commitment(), Commitment()          # the manoeuvre each override leaves
            assert fast.check(a, dist, err, p, commit=mine) == plain.check(a, dist, err, p, commit=theirs), case
            assert mine.plan == theirs.plan, case
            plans.add(mine.plan)
    finally:
        SafetyShield.horizon_margins = inner
    assert sum(c is not None for c in calls) > 20                  # the boxed-in branch really ran
    assert len(plans) > 5                                          # and overrides left various manoeuvres


def test_first_safe_continuation_as_with_every_pair():
    # Past the first chunk of continuations, _margin_at finds the chunk that clears the floor with
    # capped clearances and measures only that one: the same side of the floor, the same index.
    fast, plain = SafetyShield(lambda obs: np.zeros(1)), PlainShield(lambda obs: np.zeros(1))
    rng = np.random.default_rng(3)
    late = 0
    for case in range(80):
        q, rel = random_returns(rng, int(rng.integers(10, 160)), moving=(0.0, 0.3)[case % 2])
        q *= 0.4
        drift = rel[0]
        goal = rng.uniform(-8, 8, 2) if case % 3 == 0 else None
        look = fast._look(q, rel, goal, drift, int(rng.choice([5, 10])), bool(case % 2))
        for a in np.linspace(-1.0, 1.0, 21):
            m, idx = fast._margin_at(float(a), look, fast.min_clearance)
            want, want_idx = plain._margin_at(float(a), look, fast.min_clearance)
            assert (m >= fast.min_clearance) == (want >= fast.min_clearance), (case, a)
            if want >= fast.min_clearance:
                assert (m, idx) == (want, want_idx), (case, a)
                late += int(idx >= CHUNK)
    assert late > 20                                               # found past the first chunk too


class PerCluster(ReturnMotion):
    """``ReturnMotion.update`` written one cluster at a time (as it was until session 31)."""

    def update(self, points_body, pose, t):
        pts = np.asarray(points_body, dtype=np.float64).reshape(-1, 2)
        vel = np.zeros_like(pts)
        world = to_map(pts, pose)
        labels = self._clusters(world)
        n_clusters = int(labels.max()) + 1 if len(labels) else 0
        raw = np.full((n_clusters, 2), np.nan)
        prev, prev_labels, dt, prev_raw = self._prev, self._prev_labels, t - self._prev_t, self._prev_raw
        self._prev, self._prev_labels, self._prev_t, self._prev_raw = world, labels, t, raw
        if prev is None or len(prev) == 0 or len(pts) == 0 or dt <= 0:
            return vel
        a, b = self._segments(prev, prev_labels)
        moving = _cluster_medians(_point_segment_distance(world, a, b), labels, n_clusters) > self.still
        prev_cents = np.array([prev[prev_labels == k].mean(axis=0) for k in range(prev_labels.max() + 1)])
        for k in np.flatnonzero(moving):
            c = world[labels == k].mean(axis=0)
            d = np.linalg.norm(prev_cents - c, axis=1)
            j = int(np.argmin(d))
            if d[j] <= self.gate:
                v = (c - prev_cents[j]) / dt
                if self.min_speed <= float(np.hypot(*v)) <= self.max_speed:
                    raw[k] = v
                    if self.agree > 0 and not np.hypot(*(v - prev_raw[j])) <= self.agree:
                        continue
                    vel[labels == k] = to_body(v, pose[2])
        return vel


def test_return_motion_matches_the_per_cluster_computation():
    # Schools that swim (each its own speed and heading), squares and the net, seen by the study
    # sonar from a vehicle that moves and turns: every velocity the same bits, moving ones included.
    sonar = SonarModel()
    rng = np.random.default_rng(3)
    moved = 0
    for agree in (0.0, 0.5):
        for run in range(4):
            fish = tuple(Obstacle("circle", *rng.uniform(-8, 8, 2), float(rng.uniform(0.5, 1.5)),
                                  *rng.uniform(-5, 5, 2), float(rng.uniform(20, 40)))   # oscillating schools
                         for _ in range(3))
            squares = tuple(Obstacle("square", *rng.uniform(-10, 10, 2), 1.0) for _ in range(3))
            world = World(15.0, (), squares + fish)
            fast, plain = ReturnMotion(agree=agree), PerCluster(agree=agree)
            x, y, yaw = 0.0, 0.0, float(rng.uniform(-math.pi, math.pi))
            for k in range(40):
                t = float(k)
                r = sonar.scan(world, x, y, yaw, t)
                ang = np.arange(len(r)) * (2 * math.pi / len(r))
                seen = np.isfinite(r) & (r < 15.0)
                q = np.stack([r[seen] * np.cos(ang[seen]), r[seen] * np.sin(ang[seen])], axis=1)
                got, want = fast.update(q, (x, y, yaw), t), plain.update(q, (x, y, yaw), t)
                assert np.array_equal(got, want), (agree, run, k)
                moved += int((want != 0).any(axis=1).sum())
                yaw += float(rng.uniform(-0.3, 0.3))
                x, y = x + 0.3 * math.cos(yaw), y + 0.3 * math.sin(yaw)
    assert moved > 50                                         # velocities were really estimated


def test_centroids_equal_numpy_mean_per_cluster():
    # np.add.reduceat's sums differ from mean(axis=0)'s in the last bit (docs/notes/reactive.md); bincount's
    # are made in the same order, so every centroid must be the same bits, any cluster size.
    from cage_sim.perception import _centroids
    rng = np.random.default_rng(0)
    for _ in range(500):
        n = int(rng.integers(1, 200))
        labels = np.unique(np.sort(rng.integers(0, int(rng.integers(1, 20)), n)), return_inverse=True)[1]
        pts = rng.normal(0, 10, (n, 2)) + rng.uniform(-50, 50, 2)
        want = np.array([pts[labels == k].mean(axis=0) for k in range(labels.max() + 1)])
        assert np.array_equal(_centroids(pts, labels, labels.max() + 1), want)
