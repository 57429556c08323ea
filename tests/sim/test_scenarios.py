"""Scenario generators and strict scenario files."""
import math

import numpy as np
import pytest
import yaml

from cage_sim.scenarios import (CageParams, ScenarioError, builtin_file, generate_cage, generate_study2d,
                                load_scenario, save_scenario, scenario_from_dict)

GOOD = {"name": "t", "start": [0.0, 0.0, 90.0], "goal": [10.0, 0.0],
        "known_obstacles": [{"shape": "square", "x": 5.0, "y": 5.0, "size": 2.0}]}


def test_generators_are_seeded_and_valid():
    for gen in (generate_study2d, generate_cage):
        a, b = gen(np.random.default_rng(7)), gen(np.random.default_rng(7))
        assert a == b
        assert a != gen(np.random.default_rng(8))
        a.validate()


def test_cage_generator_defaults_match_the_study_cage():
    sc = generate_cage(np.random.default_rng(0), CageParams(n_moving=2, current_speed=0.1))
    w = sc.world
    assert w.net_radius == 30.0 and len(w.known) == 20
    assert all(o.shape == "square" and o.size == 2.0 for o in w.known)
    assert len(w.unknown) >= 10 and sum(o.moving for o in w.unknown) == 2
    assert math.hypot(*w.current) == pytest.approx(0.1)
    assert math.dist(sc.start[:2], sc.goal) >= 20.0


def test_study2d_has_one_obstacle_between_start_and_goal():
    sc = generate_study2d(np.random.default_rng(3))
    (ob,) = sc.world.obstacles
    s, g = np.array(sc.start[:2]), np.array(sc.goal)
    u = (g - s) / np.linalg.norm(g - s)
    along = float(np.dot(np.array([ob.x, ob.y]) - s, u)) / np.linalg.norm(g - s)
    assert 0.3 <= along <= 0.7


def test_round_trip_file(tmp_path):
    sc = generate_cage(np.random.default_rng(2), CageParams(n_moving=1))
    save_scenario(sc, tmp_path / "s.yaml")
    back = load_scenario(tmp_path / "s.yaml")
    assert back.world.known == sc.world.known or len(back.world.known) == len(sc.world.known)
    assert back.goal == pytest.approx(sc.goal)


def test_builtin_full_cage_loads():
    sc = builtin_file("full_cage.yaml")
    assert sc.name == "full_cage" and len(sc.world.known) == 20


@pytest.mark.parametrize("patch, field", [
    ({"goal": [40.0, 0.0]}, "goal"),
    ({"start": [5.0, 5.0, 0.0]}, "start"),
    ({"colour": "red"}, "colour"),
    ({"net_radius": "big"}, "net_radius"),
    ({"goal": [1.0]}, "goal"),
    ({"known_obstacles": [{"shape": "hexagon", "x": 1.0, "y": 1.0, "size": 1.0}]}, "known_obstacles[0].shape"),
    ({"known_obstacles": [{"shape": "square", "x": 1.0, "y": 1.0}]}, "known_obstacles[0].size"),
    ({"unknown_obstacles": [{"shape": "circle", "x": 1.0, "y": 1.0, "size": 1.0, "speed": 2}]},
     "unknown_obstacles[0].speed"),
    ({"waypoints": [[0.0, 50.0]]}, "waypoints[0]"),
    ({"current": [0.0, True]}, "current[1]"),
])
def test_invalid_files_name_the_field(tmp_path, patch, field):
    data = {**GOOD, **patch}
    p = tmp_path / "bad.yaml"
    p.write_text(yaml.safe_dump(data))
    with pytest.raises(ScenarioError) as err:
        load_scenario(p)
    assert str(err.value).startswith(field), str(err.value)


def test_missing_required_and_not_yaml(tmp_path):
    with pytest.raises(ScenarioError, match="^goal: missing"):
        scenario_from_dict({"start": [0.0, 0.0, 0.0]})
    p = tmp_path / "x.yaml"
    p.write_text("start: [1, 2\n")
    with pytest.raises(ScenarioError, match="not valid YAML"):
        load_scenario(p)
