"""``ArcController(remembered="out_of_view")``: the shield and the baseline count a remembered return
only where the sonar does not look now. A school remembered dead ahead that the 360 deg scan no
longer shows (it fled) blocks the way with every remembered return counted, and not without; a
forward-looking sonar keeps what it remembers beside and behind."""
import math

import numpy as np
import pytest
from cage_sim.controller import ArcController, remembered_bins
from cage_sim.mission import EnvConfig
from cage_sim.perception import Perception
from cage_sim.shield import SafetyShield


def observation(layout, memory: np.ndarray) -> np.ndarray:
    """An empty scan (nothing in range), the waypoint 15 m dead ahead, no drift, ``memory`` (m)."""
    ranges = np.full(layout.n_beams, np.inf)
    return layout.build(ranges if layout.scan else None, 15.0, 0.0, np.array([1.0, 0.0]) if layout.velocity else None,
                        memory)


def test_a_360_deg_scan_keeps_no_remembered_bin_a_sector_scan_those_outside_it():
    mb = EnvConfig(sonar="multibeam360", velocity=True, memory_bins=72).layout
    assert len(remembered_bins(mb, "all")) == 72 and len(remembered_bins(mb, "out_of_view")) == 0
    fls = EnvConfig(sonar="fls", velocity=True, memory_bins=72).layout      # 130 deg ahead
    kept = set(remembered_bins(fls, "out_of_view").tolist())
    deg = {i: i * 5 if i * 5 <= 180 else i * 5 - 360 for i in range(72)}
    assert kept == {i for i, a in deg.items() if abs(a) + 2.5 > 65}   # a 5 deg bin wholly within +-65 deg: dropped
    assert not {0, 12, 60} & kept and {13, 14, 36, 58, 59} <= kept   # 60 deg (57.5-62.5) in view; 65 deg straddles


def test_a_fled_school_remembered_ahead_blocks_the_way_only_when_every_remembered_return_counts():
    layout = EnvConfig(sonar="multibeam360", velocity=True, memory_bins=72).layout
    memory = np.full(72, np.inf)
    memory[0] = 3.0                                     # remembered 3 m dead ahead; the scan is empty now
    obs = observation(layout, memory)
    every, in_view = ArcController(layout), ArcController(layout, remembered="out_of_view")
    assert np.allclose(every.returns(obs), [[3.0, 0.0]]) and len(in_view.returns(obs)) == 0
    for ctrl, blocked in ((every, True), (in_view, False)):
        shield = SafetyShield(ctrl, ctrl)
        action = shield.check(0.0, 15.0, 0.0, Perception(ctrl.returns(obs)))   # the policy flies straight on
        assert (abs(action) > 0.05) == blocked
        assert shield.interventions == int(blocked)


def test_a_forward_looking_sonar_keeps_what_it_remembers_behind():
    layout = EnvConfig(sonar="fls", velocity=True, memory_bins=72).layout
    memory = np.full(72, np.inf)
    memory[36], memory[2] = 4.0, 5.0                    # 4 m behind (out of view), 5 m at 10 deg (in view)
    pts = ArcController(layout, remembered="out_of_view").returns(observation(layout, memory))
    assert np.allclose(pts, [[-4.0, 0.0]], atol=1e-9)
    every = ArcController(layout).returns(observation(layout, memory))
    assert len(every) == 2 and np.allclose(sorted(np.hypot(*every.T)), [4.0, 5.0])
    assert math.isclose(math.degrees(math.atan2(every[0, 1], every[0, 0])) % 360, 10.0, abs_tol=1e-6)


def test_a_bad_value_is_refused_naming_the_field():
    with pytest.raises(ValueError, match="remembered: must be one of all, out_of_view"):
        ArcController(remembered="none")
