"""The shield's goal search table: its answers are those of testing every point of every manoeuvre."""
import numpy as np
import pytest

from cage_sim.controller import nearest_distance
from cage_sim.goal_search import GoalSearch
from cage_sim.shield import SafetyShield


class Straight:
    def act(self, obs):
        return np.zeros((1,), dtype=np.float32)


def brute_force(table: GoalSearch, rank, goal, drift, t_first, t_cont, returns, rel, goal_pass, clearance):
    """The definition: every manoeuvre (first action f, continuation c) flown point by point; its
    first point within ``goal_pass`` of the drifting goal ends it; the soonest such manoeuvre that keeps
    ``clearance`` up to there wins, ties to the lowest rank."""
    times = np.concatenate([t_first, t_cont])
    n_f, n_c = table.points.shape[:2]
    found = []
    for f in range(n_f):
        for c in range(n_c):
            path = np.concatenate([table.first[f], table.points[f, c]])
            near = np.linalg.norm(path + times[:, None] * drift - goal, axis=1) < goal_pass
            if near.any():
                when = int(np.argmax(near))
                d = nearest_distance(path[:when + 1], times[:when + 1], rel, returns).min()
                found.append((when, rank[f], f, d >= clearance))
    passing = sorted(x for x in found if x[3])
    return passing[0][2] if passing else None


@pytest.fixture(scope="module")
def shield():
    return SafetyShield(Straight())


@pytest.mark.parametrize("horizon, options", [(6, {}), (15, {}), (9, {"s_turns": False, "n_actions": 11})])
def test_goal_search_table_answers_as_every_point_of_every_manoeuvre(horizon, options):
    shield = SafetyShield(Straight(), **options)
    table = shield._goal_table(horizon)
    t_first, t_cont = shield._motion(np.zeros((0, 2)), None, None, None, horizon)[:2]
    rng = np.random.default_rng(3)
    answers = []
    for _ in range(12 if horizon == 15 else 30):
        goal = rng.uniform(-horizon * 0.7, horizon * 0.7, size=2)
        drift = rng.uniform(-0.5, 0.5, size=2)
        returns = rng.uniform(-1.5 * horizon, 1.5 * horizon, size=(int(rng.integers(3, 40)), 2))
        rel = np.tile(-drift, (len(returns), 1))
        rel[: len(rel) // 3] += rng.uniform(-0.3, 0.3, size=2)        # a school moving on its own
        rank = rng.permutation(len(table.first))
        args = (rank, goal, drift, t_first, t_cont, returns, rel, 0.8, 1.0)
        expect = brute_force(table, *args)
        assert table.find(*args) == expect
        answers.append(expect)
    assert any(a is None for a in answers) and sum(a is not None for a in answers) >= 3   # both kinds met


def test_goal_search_table_nodes_are_shared_ways(shield):
    table = shield._goal_table(15)
    n_f, n_c, n_p = table.node.shape
    # a node's manoeuvres fly the same points up to it, and different nodes of a slot lie apart
    for p in (0, 7, n_p - 1):
        ids = table.node[:, :, p]
        pts = table.points[:, :, p]
        for i in np.unique(ids)[:: 97]:
            f, c = np.nonzero(ids == i)
            assert (f == f[0]).all() and np.allclose(pts[f, c], pts[f[0], c[0]], atol=0)
            assert table.node_f[i] == f[0] and table.node_c[i] == c.min() and table.node_slot[i] == p
    assert len(table.node_f) < 0.6 * n_f * n_c * n_p          # the shared ways: fewer points to test


def test_prepare_builds_the_table_the_search_uses_once_per_process():
    a = SafetyShield(Straight()).prepare()
    b = SafetyShield(Straight())
    assert list(a._tables) == [(15, True)]                    # goal_horizon 15 covers look-aheads 5-10
    assert b._goal_table(15) is a._tables[(15, True)]         # shared: built once per process
    assert SafetyShield(Straight(), goal_search=False).prepare()._tables == {}
