"""Current field, current-deformed net, fleeing fish, drift, velocity over ground, scenario validation."""
import math

import numpy as np
import pytest

from cage_sim.current import CurrentField, CurrentMode, random_field
from cage_sim.fish import FishSchool, FishState
from cage_sim.mission import EnvConfig, Mission
from cage_sim.net import NetShape, loss_for_current
from cage_sim.scenarios import Scenario, ScenarioError, make_generator, scenario_from_dict
from cage_sim.sonar import make_sonar
from cage_sim.vehicle import VehicleParams, advance, propagate, velocity_over_ground
from cage_sim.world import World


def test_random_current_field_stays_within_its_cap():
    rng = np.random.default_rng(0)
    for speed in (0.0, 0.25, 0.5):
        f = random_field(rng, speed, n_modes=3, variation=0.3)
        xs, ys = rng.uniform(-30, 30, (2, 2000))
        vx, vy = f.velocity(xs, ys, rng.uniform(0, 600))
        sp = np.hypot(vx, vy)
        assert sp.max() <= f.max_speed + 1e-12 <= speed * 1.3 + 1e-9
        if speed:
            assert sp.std() > 0.0                                  # it varies in space
            assert f.velocity(3.0, 4.0, 10.0) == pytest.approx(tuple(v[0] for v in f.velocity(np.array([3.0]), np.array([4.0]), 10.0)))


@pytest.mark.parametrize("outside, loss", [(0.13, 0.20), (0.35, 0.40), (0.5, 0.40)])
def test_net_area_loss_follows_the_full_scale_measurements(outside, loss):
    inside = outside * 0.85
    net = NetShape.from_current(30.0, (inside, 0.0))
    assert net.loss == pytest.approx(loss, abs=1e-9)
    assert net.area_loss() == pytest.approx(loss, abs=0.002)           # the polygon the sonar sees
    # the upstream wall (flow comes from -x) is pushed in; the downstream wall stays at R
    assert net.r(math.pi) < 30.0 * (1 - loss / 2) and net.r(0.0) == pytest.approx(30.0)
    assert loss_for_current(inside) == net.loss
    with pytest.raises(ValueError, match="current speed must be >= 0"):
        loss_for_current(-0.1)


def test_sonar_and_collision_see_the_deformed_wall_the_map_does_not():
    w = World(30.0, current=(0.3, 0.0), net_loss=None)
    upstream = float(w.net.r(math.pi))
    r = make_sonar("study").scan(w, 0.0, 0.0, math.pi)[0]
    assert r == pytest.approx(upstream, abs=0.01) and upstream < 20.0
    assert w.clearance(-upstream + 0.2, 0.0) == pytest.approx(0.2, abs=0.01)
    assert w.known_map().net.loss == 0.0 and w.known_map().clearance(-upstream + 0.2, 0.0) > 10.0
    assert not w.inside_net(-upstream - 1.0, 0.0) and w.known_map().inside_net(-upstream - 1.0, 0.0)


def test_fish_flee_from_the_vehicle_and_close_in_again():
    school = FishSchool(5.0, 0.0, radius=1.0, flee_radius=3.0, flee_speed=0.8, return_speed=0.3, wander=0.0)
    fish = FishState((school,), 30.0, seed=1)
    for _ in range(5):
        fish.step(1.0, (2.0, 0.0))                                  # vehicle 3 m away: inside flee range
    fled = fish.pos[0].copy()
    assert fled[0] > 6.5                   # swam away along +x, past where it first took fright (6 m)
    for _ in range(60):
        fish.step(1.0, (-20.0, 0.0))                                # vehicle gone
    assert math.dist(fish.pos[0], (5.0, 0.0)) < 0.5                 # back home
    again = FishState((school,), 30.0, seed=1)
    for _ in range(5):
        again.step(1.0, (2.0, 0.0))
    assert np.array_equal(again.pos[0], fled)                        # deterministic


def test_uniform_current_keeps_the_closed_form_and_a_varying_one_converges():
    p = VehicleParams()
    uniform = CurrentField((0.2, -0.1))
    assert advance(0.0, 0.0, 0.0, 0.3, 1.0, p, uniform) == propagate(0.0, 0.0, 0.0, 0.3, 1.0, current=(0.2, -0.1))
    # many small vehicle-node ticks == one decision step, for a varying field too (same function)
    f = CurrentField((0.2, 0.0), (CurrentMode(0.1, 0.05, 0.2, 0.1, 0.05, 0.3),))
    one = advance(1.0, 2.0, 0.4, 0.9, 1.0, p, f, t=5.0)
    x, y, yaw = 1.0, 2.0, 0.4
    for k in range(10):
        x, y, yaw = advance(x, y, yaw, 0.9, 0.1, p, f, t=5.0 + 0.1 * k)
    assert (x, y, yaw) == pytest.approx(one, abs=1e-12)


def test_velocity_over_ground_shows_the_drift():
    u, v = velocity_over_ground(math.pi / 2, 1.0, (0.3, 0.0))     # heading north, current east
    assert u == pytest.approx(1.0) and v == pytest.approx(-0.3)      # drift to the right
    sc = Scenario("s", World(30.0, current=(0.0, 0.25)), (0.0, 0.0, 0.0), (10.0, 0.0))
    m = Mission(sc, EnvConfig())
    assert m.velocity_over_ground() == pytest.approx((1.0, 0.25))


@pytest.mark.parametrize("patch, field", [
    ({"current": [0.95, 0.0]}, "current"), ({"net_deformation": 0.8}, "net_deformation"),
    ({"fish_schools": [{"x": 1.0, "y": 2.0, "flee_speed": -1.0}]}, "fish_schools[0].flee_speed"),
    ({"fish_schools": [{"x": 1.0}]}, "fish_schools[0].y"), ({"sensor": "lidar"}, "sensor"),
    ({"current_modes": [{"ax": 0.5, "ay": 0.5}]}, "current_modes"),
])
def test_bad_water_in_a_scenario_file_is_refused_naming_the_field(patch, field):
    base = {"start": [0.0, 0.0, 0.0], "goal": [10.0, 0.0], "current": [0.3, 0.0]}
    with pytest.raises(ScenarioError, match=f"^{re_escape(field)}"):
        scenario_from_dict(base | patch)


def re_escape(s: str) -> str:
    import re
    return re.escape(s)


def test_a_current_as_fast_as_the_vehicle_is_refused_by_the_mission():
    sc = Scenario("s", World(30.0, current=(1.0, 0.0)), (0.0, 0.0, 0.0), (10.0, 0.0))
    with pytest.raises(ValueError, match="^current: .* not slower than the vehicle"):
        Mission(sc, EnvConfig())


def test_a_family_draws_what_it_names():
    g = make_generator("cage?current=0.5&obstacles=small&goal=near_net&schools=3&sensor=fls")
    for seed in range(3):
        sc = g(np.random.default_rng(seed))
        w = sc.world
        assert math.hypot(*w.current) == pytest.approx(0.5) and w.current_modes
        assert w.net.loss == pytest.approx(0.4) and len(w.schools) == 3 and sc.sensor == "fls"
        assert all(0.15 <= (o.size if o.shape == "circle" else o.size / 2) <= 0.3 for o in w.unknown)
        assert w.net.clearance(*sc.goal) == pytest.approx(2.5, abs=0.01)
        sc.validate()
    still = make_generator("cage?current=0")(np.random.default_rng(0)).world
    assert still.net.loss == 0.0 and not still.current_modes


@pytest.mark.parametrize("spec, key", [("cage?current=-1", "current"), ("cage?current=1.2", "current_speed"),
                                       ("cage?size=2", "size"), ("cage?net=0.9", "net_deformation"),
                                       ("cage?schools=many", "schools"), ("lake?current=0.1", "base")])
def test_bad_families_name_the_key(spec, key):
    with pytest.raises(ScenarioError, match=f"{key}:"):
        make_generator(spec)


def _brute_wall(poly: np.ndarray, px: float, py: float, a: float) -> float:
    """Every edge of the wall polygon against the ray (the reference for the kernel's culled search)."""
    best = math.inf
    for k in range(len(poly)):
        (ax, ay), (bx, by) = poly[k], poly[(k + 1) % len(poly)]
        ex, ey, dx, dy = bx - ax, by - ay, math.cos(a), math.sin(a)
        den = dx * ey - dy * ex
        if den:
            wx, wy = ax - px, ay - py
            t, u = (wx * ey - wy * ex) / den, (wx * dy - wy * dx) / den
            if t >= 0 and 0 <= u <= 1:
                best = min(best, t)
    return best


def test_deformed_wall_rays_equal_a_test_of_every_edge():
    w = World(30.0, current=(0.35, 0.1), net_loss=None)
    s = make_sonar("study", max_range=60.0)
    rng = np.random.default_rng(0)
    checked = 0
    while checked < 8:
        r, th, yaw = rng.uniform(0, 28), rng.uniform(-math.pi, math.pi), rng.uniform(-math.pi, math.pi)
        p = (r * math.cos(th), r * math.sin(th))
        if not w.inside_net(*p):
            continue
        got = s.scan(w, *p, yaw)
        ref = [_brute_wall(w.net.polygon, *p, yaw + a) for a in s.angles]
        assert got == pytest.approx(ref, abs=1e-9)
        checked += 1


def test_fish_are_seen_by_the_sonar_and_hit_in_the_mission():
    school = FishSchool(4.0, 0.0, radius=1.0, flee_radius=0.0, flee_speed=0.0, return_speed=0.0, wander=0.0)
    sc = Scenario("s", World(30.0, schools=(school,)), (0.0, 0.0, 0.0), (10.0, 0.0))
    m = Mission(sc, EnvConfig())
    assert m.scan()[0] == pytest.approx(3.0)
    outcome = None
    for _ in range(4):
        _, outcome = m.step(0.0)
        if outcome:
            break
    assert outcome == "collision"


def test_sea_scenario_file_round_trips(tmp_path):
    from cage_sim.scenarios import builtin_file, load_scenario, save_scenario
    sc = builtin_file("sea_cage.yaml")
    w = sc.world
    assert sc.sensor == "fls" and w.current_modes and w.net.loss == pytest.approx(0.4) and len(w.schools) == 2
    save_scenario(sc, tmp_path / "again.yaml")
    back = load_scenario(tmp_path / "again.yaml")
    assert back.world == w and back.sensor == sc.sensor and back.goal == sc.goal


@pytest.mark.parametrize("moving", [False, True])
def test_world_clearance_is_the_nearest_of_net_obstacles_and_fish(moving):
    """World.clearance (packed arrays) against the one-obstacle-at-a-time definition, deformed net and
    schools included, inside obstacles (negative) and out."""
    from cage_sim.world import Obstacle
    rng = np.random.default_rng(3)
    obs = tuple(Obstacle(str(rng.choice(["square", "circle"])), *rng.uniform(-20, 20, 2), rng.uniform(0.15, 2.0),
                         *((rng.uniform(-2, 2, 2).tolist() + [rng.uniform(5, 30)]) if moving and i % 3 == 0 else ()))
                for i in range(25))
    w = World(30.0, obs[:10], obs[10:], current=(0.3, 0.1)).with_fish(np.array([[4.0, -5.0, 1.5], [-8.0, 2.0, 2.0]]))
    pts = np.vstack([rng.uniform(-29, 29, (300, 2)), [[o.x, o.y] for o in obs]])
    for t in (0.0, 7.3):
        for x, y in pts:
            want = min([w.net.clearance(x, y)] + [o.distance(x, y, t) for o in obs]
                       + [math.hypot(x - cx, y - cy) - r for cx, cy, r in w.fish_circles])
            assert w.clearance(x, y, t) == want                  # bit for bit: published runs stay reproducible
    assert min(w.clearance(o.x, o.y, 0.0) for o in obs if not o.moving) < 0          # inside an obstacle


def test_a_seeded_mission_moves_its_schools_alike_in_the_env_and_as_sim_node_builds_it():
    """sim_node (and evaluate, and the vector env) build ``Mission(draw_scenario(spec, seed), config)``;
    the Gymnasium env must fly the very same schools, or graph and offline part ways (seen until
    session 41: the env drew the schools' seed from its own stream)."""
    from cage_sim.env import CageNavEnv
    from cage_sim.scenarios import draw_scenario
    spec = "cage?current=0.25&schools=3"
    for seed in (3, 4):
        env = CageNavEnv(spec)
        env.reset(seed=seed)
        node_side = Mission(draw_scenario(spec, seed), EnvConfig())
        assert node_side.fish is not None and len(node_side.fish) == 3
        for a in (0.3, -0.2, 0.0, 0.5, -0.6, 0.1):
            env.step(np.array([a], dtype=np.float32))
            node_side.step(a)
            assert np.array_equal(env.unwrapped.mission.fish.pos, node_side.fish.pos)
        assert env.unwrapped.mission.fish.pos.tolist() != node_side.fish.home.tolist()   # they did move


def test_a_mission_carries_on_the_schools_of_an_earlier_one_and_refuses_other_ones():
    school = FishSchool(6.0, 0.0, radius=1.0, flee_radius=3.0, flee_speed=0.8, return_speed=0.3, wander=1.0)
    sc = Scenario("s", World(30.0, schools=(school,)), (0.0, 0.0, 0.0), (-10.0, 0.0))
    first = Mission(sc, EnvConfig())
    for _ in range(4):
        first.step(0.0)                                      # toward the school: it flees
    fled = first.fish.pos.copy()
    assert fled[0, 0] > 6.5
    second = Mission(sc, EnvConfig(), fish=first.fish)       # the next goal, in the same water
    assert second.fish is first.fish and np.array_equal(second.fish.pos, fled)
    assert np.array_equal(Mission(sc, EnvConfig()).fish.pos, [[6.0, 0.0]])   # a new episode: at home
    other = Scenario("o", World(30.0, schools=(FishSchool(-6.0, 0.0),)), (0.0, 0.0, 0.0), (10.0, 0.0))
    with pytest.raises(ValueError, match="fish"):
        Mission(other, EnvConfig(), fish=first.fish)
