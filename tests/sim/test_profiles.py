"""Sensor profiles: beam cones, the forward sector, the mechanical head's sweep ages, validation."""
import math

import numpy as np
import pytest

from cage_sim.scenarios import generate_cage
from cage_sim.sonar import PROFILE_NAMES, SonarConfigError, SonarModel, make_sonar
from cage_sim.world import Obstacle, World


def test_study_profile_is_the_original_model_bit_for_bit():
    assert make_sonar("study") == SonarModel()
    rng = np.random.default_rng(0)
    worlds = [generate_cage(np.random.default_rng(i)).world for i in range(8)]
    poses = np.c_[rng.uniform(-15, 15, (8, 2)), rng.uniform(-3, 3, 8)]
    ref = SonarModel().scan_batch(worlds, poses)
    assert np.array_equal(make_sonar("study").scan_batch(worlds, poses), ref)


def test_a_beam_cone_finds_a_small_circle_between_the_study_rays():
    # A 0.15 m circle 10 m away, 2.5 deg off the axis: between two ideal rays 5 deg apart.
    a = math.radians(2.5)
    w = World(30.0, (), (Obstacle("circle", 10 * math.cos(a), 10 * math.sin(a), 0.15),))
    assert np.all(np.isinf(make_sonar("study").scan(w, 0.0, 0.0, 0.0)[:2]))
    r = make_sonar("multibeam360", beam_width_deg=5.0, noise_std=0.0, dropout=0.0).scan(w, 0.0, 0.0, 0.0)
    assert r[0] == pytest.approx(9.85) and r[1] == pytest.approx(9.85)   # nearest point: 10 - 0.15
    assert np.isinf(r[2])


def test_multibeam360_beams_are_2_deg_wide_5_deg_apart():
    """A real head's 1-2 deg beams: the same small circle 10 m away, 2.5 deg off the axis, spans
    1.6-3.4 deg and falls between beam 0 (+-1 deg) and beam 1 (4-6 deg); 4 m away it spans 0.4-4.6
    deg and both beams see it. A wide obstacle no longer looks 2.5 deg wider on each side."""
    mb = make_sonar("multibeam360", noise_std=0.0, dropout=0.0)
    assert mb.n_beams == 72 and math.degrees(mb.beam_width) == pytest.approx(2.0)
    assert math.degrees(mb.angle_increment) == pytest.approx(5.0)
    a = math.radians(2.5)
    for d, seen in ((10.0, False), (4.0, True)):
        w = World(30.0, (), (Obstacle("circle", d * math.cos(a), d * math.sin(a), 0.15),))
        r = mb.scan(w, 0.0, 0.0, 0.0)
        assert np.isfinite(r[:2]).all() == seen and np.isinf(r[2:]).all()
    # a 1.4 m circle 10 m dead ahead spans +-8.05 deg: the 2 deg beams at -5, 0, 5 deg see it, those
    # at +-10 deg (9-11 deg) do not; 5 deg cones at +-10 deg (7.5-12.5 deg) do: it looks 5 deg wider
    w = World(30.0, (), (Obstacle("circle", 10.0, 0.0, 1.4),))
    hits = lambda s: int(np.isfinite(s.scan(w, 0.0, 0.0, 0.0)).sum())   # noqa: E731
    assert hits(mb) == 3 and hits(make_sonar("multibeam360", beam_width_deg=5.0, noise_std=0.0, dropout=0.0)) == 5


def test_cone_with_zero_width_equals_the_ideal_ray():
    rng = np.random.default_rng(1)
    w = generate_cage(np.random.default_rng(3)).world
    ideal = make_sonar("study")
    cone = make_sonar("study", beam_width_deg=1e-12)
    for _ in range(5):
        x, y, yaw = *rng.uniform(-15, 15, 2), rng.uniform(-3, 3)
        assert np.allclose(cone.scan(w, x, y, yaw), ideal.scan(w, x, y, yaw), atol=1e-6)


def test_fls_sees_nothing_behind_and_its_sector_ahead():
    fls = make_sonar("fls", noise_std=0.0, dropout=0.0)
    assert math.degrees(fls.fov) == pytest.approx(130.0)
    assert fls.n_beams == 64 and math.degrees(fls.beam_width) == pytest.approx(130 / 64)
    w = World(30.0, (), (Obstacle("circle", -5.0, 0.0, 1.0),))
    assert np.all(np.isinf(fls.scan(w, 0.0, 0.0, 0.0)))          # obstacle behind
    ahead = fls.scan(w, 0.0, 0.0, math.pi)
    assert np.nanmin(ahead) == pytest.approx(4.0)


def test_scanning_head_sweeps_one_beam_at_a_time_and_ages_its_beams():
    s = make_sonar("scanning", noise_std=0.0, dropout=0.0)
    assert s.n_beams == 180 and s.sweep_time == 4.0
    assert s.time_increment == pytest.approx(4.0 / 180)
    w = World(10.0)
    head = s.head()
    first = head.reset(w, 0.0, 0.0, 0.0, 0.0)
    assert first.new.all() and first.ages(0.0).max() == pytest.approx(4.0 - s.time_increment)
    scan = head.update(w, 1.0, 0.0, 0.0, 1.0)
    assert scan.new.sum() == 45                                   # 1 s of a 4 s sweep
    ages = scan.ages(1.0)
    assert ages[scan.new].max() < 1.0 and ages[~scan.new].min() >= 1.0 - 1e-9
    # the new beams were fired from poses along the way from x = 0 to x = 1
    xs = scan.origins[scan.new, 0]
    assert xs.min() > 0.0 and xs.max() == pytest.approx(1.0)
    # each new beam was measured from its own pose: beam 0 (ahead) hits the 10 m net at 10 - x
    assert scan.ranges[0] == pytest.approx(10.0 - scan.origins[0, 0]) and scan.origins[0, 0] > 0.0
    assert scan.ranges[90] == pytest.approx(10.0)                # beam 90 (behind) is from the start sweep
    assert head.last_beam == 44


def test_dropout_and_clutter_corrupt_only_when_asked():
    w = World(30.0, (), (Obstacle("circle", 5.0, 0.0, 1.0),))
    s = make_sonar("multibeam360", dropout=0.5, noise_std=0.0, clutter=0.0)
    r = s.scan(w, 0.0, 0.0, 0.0, rng=np.random.default_rng(0))
    assert 0 < np.isinf(r).sum() < 72
    c = make_sonar("multibeam360", dropout=0.0, noise_std=0.0, clutter=0.9)
    r = c.scan(w, 0.0, 0.0, 0.0, rng=np.random.default_rng(0))
    assert np.isfinite(r).sum() > 50 and np.all(r[np.isfinite(r)] <= 10.0)


@pytest.mark.parametrize("kwargs, field", [
    ({"dropout": 1.5}, "sonar.dropout"), ({"n_beams": 0}, "sonar.n_beams"), ({"fov_deg": 400}, "sonar.fov_deg"),
    ({"beam_width_deg": -1}, "sonar.beam_width"), ({"max_range": 0}, "sonar.max_range"),
    ({"colour": 1}, "sonar.colour"), ({"sweep_time": -2}, "sonar.sweep_time"), ({"rate_hz": "fast"}, "sonar.rate_hz"),
])
def test_bad_settings_are_refused_naming_the_field(kwargs, field):
    with pytest.raises(SonarConfigError, match=f"^{field}"):
        make_sonar("fls", **kwargs)


def test_unknown_profile_is_refused_naming_the_choices():
    with pytest.raises(SonarConfigError, match="sonar.profile: must be one of"):
        make_sonar("lidar")
    assert set(PROFILE_NAMES) == {"study", "multibeam360", "fls", "scanning"}


def test_a_sweep_goes_out_as_a_laserscan_from_its_oldest_beam_and_comes_back():
    from cage_sim.sonar import laserscan_fields, scan_from_laserscan
    s = make_sonar("scanning", noise_std=0.0, dropout=0.0)
    w = World(12.0, (), (Obstacle("circle", 0.0, 6.0, 1.0),))
    head = s.head()
    head.reset(w, 0.0, 0.0, 0.0, 0.0)
    scan = head.update(w, 0.5, 0.0, 0.0, 1.0)
    f = laserscan_fields(scan, s)
    assert f["stamp"] == pytest.approx(scan.stamps.min()) and f["time_increment"] == pytest.approx(4.0 / 180)
    times = f["stamp"] + np.arange(180) * f["time_increment"]
    assert np.allclose(np.sort(times), np.sort(scan.stamps))          # every beam's age is exact
    back = scan_from_laserscan(f["ranges"], f["angle_min"], f["angle_increment"], f["stamp"],
                               f["time_increment"], s, (0.5, 0.0, 0.0), previous_stamp=0.0)
    assert np.array_equal(back.ranges, scan.ranges) and np.allclose(back.stamps, scan.stamps)
    assert np.array_equal(back.new, scan.new)
    # given the two decisions' poses, the receiver places each new beam where the head fired it from
    placed = scan_from_laserscan(f["ranges"], f["angle_min"], f["angle_increment"], f["stamp"], f["time_increment"],
                                 s, (0.5, 0.0, 0.0), 0.0, ((0.0, 0.0, 0.0, 0.0), (1.0, 0.5, 0.0, 0.0)))
    assert np.allclose(placed.origins[scan.new], scan.origins[scan.new], atol=1e-9)
    assert np.ptp(placed.origins[scan.new, 0]) > 0.4          # beams along the way, not all from here
    assert np.array_equal(placed.origins[~scan.new], back.origins[~scan.new])
    with pytest.raises(ValueError, match="scan has 72 ranges, the scanning profile has 180"):
        scan_from_laserscan(np.ones(72), 0.0, f["angle_increment"], 0.0, 0.0, s, (0.0, 0.0, 0.0))
