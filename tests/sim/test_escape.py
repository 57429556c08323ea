"""Inevitable collision states (escape.py): exact for the discretised vehicle, against the mission's
own collision test, and the generator draws no start that no driver could save."""
from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from cage_sim.escape import ACTIONS, DECISIONS, escapable
from cage_sim.mission import EnvConfig, Mission
from cage_sim.scenarios import Scenario, make_generator
from cage_sim.world import Obstacle, World


def _facing(current: float) -> Scenario:
    """A vehicle pointed at an obstacle 2.8 m ahead (clearance 2.3 m to its edge plus the 0.5 m safety
    radius), the current behind it: the generator's worst start."""
    world = World(30.0, (Obstacle("circle", 3.3, 0.0, 0.5),), (), (current, 0.0))
    return Scenario("facing", world, (0.0, 0.0, 0.0), (-15.0, 5.0))


def _survivors(sc: Scenario) -> int:
    """Action sequences of DECISIONS decisions that ``Mission`` (the evaluator's judge) lets live."""
    alive = 0
    for seq in itertools.product(ACTIONS, repeat=DECISIONS):
        m = Mission(sc, EnvConfig())
        alive += all(m.step(a)[1] != "collision" for a in seq)
    return alive


@pytest.mark.parametrize("current", [0.0, 0.5])
def test_escapable_agrees_with_the_missions_collision_test(current):
    sc = _facing(current)
    assert escapable(sc.world, sc.start) == (_survivors(sc) > 0)


def test_a_strong_current_behind_makes_the_start_inescapable_calm_water_does_not():
    assert escapable(_facing(0.0).world, _facing(0.0).start)
    assert not escapable(_facing(0.5).world, _facing(0.5).start)


def test_generated_starts_under_a_strong_current_are_escapable():
    """The sea cell at 0.5 m/s drew 4 inescapable starts in 1000 before the check (its seed 2026 missions 42,
    469, 661 and 724): now each is drawn again, and every start of the family can be escaped."""
    gen = make_generator("cage?current=0.5&obstacles=default&goal=any&schools=0")
    for i in range(60):
        sc = gen(np.random.default_rng([7, i]))
        assert escapable(sc.world, sc.start), i
    # one of the missions that were inescapable, with the cell's own seed (cell 2 of sea_small)
    from cage_reactive_ddpg.matrix import MATRICES
    cell = MATRICES["sea_small"][2]
    assert math.isclose(cell.current, 0.5)
    sc = cell.sample(np.random.default_rng([2026, 2, 42]))
    assert escapable(sc.world, sc.start)
