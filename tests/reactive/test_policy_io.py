"""Policy files: round trip, and refusal of mismatched, corrupt or missing files."""
import json
import math

import numpy as np
import pytest
import torch
from cage_sim.mission import EnvConfig
from cage_sim.observation import ObservationLayout
from cage_sim.vehicle import VehicleParams

from cage_reactive_ddpg.inference import with_base
from cage_reactive_ddpg.networks import Actor
from cage_reactive_ddpg.policy import PolicyLoadError, load_policy, save_policy, shipped_path

OBS = EnvConfig().layout.size


@pytest.fixture
def saved(tmp_path):
    torch.manual_seed(0)
    actor = Actor(OBS, (16, 8))
    actor.norm.update(torch.rand(50, OBS))       # normalisation travels in the file
    wpath, mpath = save_policy(tmp_path / "p.safetensors", actor, {"note": "test"})
    return actor, wpath, mpath


def test_round_trip_gives_identical_actions(saved):
    actor, wpath, _ = saved
    pol = load_policy(wpath)
    obs = np.random.default_rng(0).random((64, OBS), dtype=np.float32)
    with torch.no_grad():
        expected = actor(torch.from_numpy(obs)).numpy()
    np.testing.assert_allclose(pol.act(obs), expected, rtol=0, atol=1e-6)   # NumPy inference == torch
    assert pol.act(obs[0]).shape == (1,)
    assert pol.metadata["note"] == "test" and pol.metadata["obs_norm"] is True
    assert pol.layout == EnvConfig().layout


def test_layout_mismatch_is_refused_naming_the_field(saved):
    _, wpath, mpath = saved
    meta = json.loads(mpath.read_text())
    meta["observation_layout"]["n_beams"] = 36
    mpath.write_text(json.dumps(meta))
    with pytest.raises(PolicyLoadError, match="n_beams: file has 36"):
        load_policy(wpath, layout=ObservationLayout())          # what the node builds
    with pytest.raises(PolicyLoadError, match="network obs_dim is 74, the layout has 38"):
        load_policy(wpath)                                      # the file disagrees with itself


def test_other_build_layout_is_refused(saved):
    _, wpath, _ = saved
    with pytest.raises(PolicyLoadError, match="max_range"):
        load_policy(wpath, layout=ObservationLayout(max_range=30.0))


def test_action_scale_mismatch_is_refused(saved):
    _, wpath, _ = saved
    with pytest.raises(PolicyLoadError, match="max_turn_deg"):
        load_policy(wpath, vehicle=VehicleParams(max_turn=math.radians(30)))


def test_size_mismatch_is_refused(saved):
    _, wpath, mpath = saved
    meta = json.loads(mpath.read_text())
    meta["network"]["actor_hidden"] = [16, 16]
    mpath.write_text(json.dumps(meta))
    with pytest.raises(PolicyLoadError, match=r"net\.2\.weight: file \(8, 16\), metadata says \(16, 16\)"):
        load_policy(wpath)


def test_corrupt_weights_are_refused(saved):
    _, wpath, _ = saved
    wpath.write_bytes(b"\x00garbage" * 10)
    with pytest.raises(PolicyLoadError, match="corrupt"):
        load_policy(wpath)


def test_truncated_weights_are_refused(saved):
    _, wpath, _ = saved
    data = wpath.read_bytes()
    wpath.write_bytes(data[: len(data) // 2])
    with pytest.raises(PolicyLoadError, match="corrupt"):
        load_policy(wpath)


def test_corrupt_metadata_and_missing_files_are_refused(saved, tmp_path):
    _, wpath, mpath = saved
    with pytest.raises(PolicyLoadError, match="not found"):
        load_policy(tmp_path / "nothing.safetensors")
    mpath.write_text("{not json")
    with pytest.raises(PolicyLoadError, match="not valid JSON"):
        load_policy(wpath)


def open_water(pol, errors) -> np.ndarray:
    """Observations for the policy's own layout (v1 or v2): nothing seen, waypoint 10 m away at the
    given heading errors, flying 1 m/s straight ahead over ground (no drift)."""
    from cage_sim.observation import ObservationBuilder
    from cage_reactive_ddpg.policy import env_config_for
    env = env_config_for(pol.metadata)
    return np.stack([ObservationBuilder(env.layout).build(np.full(env.sonar.n_beams, np.inf), 0.0, 0.0, 0.0, 0.0,
                                                          10.0, e, (1.0, 0.0)) for e in errors])


@pytest.mark.parametrize("name", ["policy", "policy_near", "policy_near_cleared"])
def test_shipped_policy_loads_and_acts(name):
    path = shipped_path().with_name(f"{name}.safetensors")
    assert path.is_file(), f"the package must ship weights/{name}.safetensors"
    pol = load_policy(path)
    obs = open_water(pol, [0.5 * math.pi, 0.0, -0.5 * math.pi])   # waypoint to the left, ahead, to the right
    a = pol.act(obs)
    assert a.shape == (3, 1) and np.all(np.abs(a) <= 1.0)
    assert a[0, 0] > 0.5 and a[2, 0] < -0.5, "with open water the policy turns toward the waypoint"
    assert "evaluation" in pol.metadata and "training" in pol.metadata


def test_the_cleared_base_policies_move_the_base_that_reads_the_cleared_memory():
    """Trained with ``expert_remembered: cleared`` (session 55): the file says so, and the loaded
    base counts the remembered returns as in training (for a 360 deg scan: none, the scan alone;
    beside a forward-looking sector: those the sonar has not seen past since)."""
    pol = load_policy(shipped_path().with_name("policy_near_cleared.safetensors"))
    assert pol.metadata["config"]["expert_remembered"] == "cleared"
    assert pol.metadata["residual_base"]["remembered"] == pol.residual_base.remembered == "cleared"
    assert not pol.residual_base.reads_memory                   # study: 360 deg, nothing kept beside it
    assert load_policy(shipped_path().with_name("policy_near.safetensors")).residual_base.remembered == "all"
    fls = load_policy(shipped_path().with_name("policy_fls_near_cleared.safetensors"), profile="fls")
    assert fls.residual_base.remembered == "cleared" and fls.residual_base.reads_memory   # beside the sector


def mission_observations(n_missions: int = 3) -> np.ndarray:
    """What the shipped policy really reads: observations (its own layout) along full-cage missions
    flown by the baseline."""
    from cage_sim.controller import ArcController
    from cage_sim.env import CageNavEnv
    from cage_reactive_ddpg.policy import env_config_for
    cfg = env_config_for(load_policy().metadata)
    env, drv, out = CageNavEnv("cage", cfg), ArcController(cfg.layout), []
    for seed in range(n_missions):
        obs, _ = env.reset(seed=seed)
        done = False
        while not done:
            out.append(obs)
            obs, _, term, trunc, _ = env.step(drv.act(obs))
            done = term or trunc
    return np.array(out, dtype=np.float32)


def test_numpy_inference_equals_torch_on_the_shipped_policy():
    from safetensors.torch import load_file
    pol = load_policy()
    meta = pol.metadata
    actor = Actor(meta["network"]["obs_dim"], meta["network"]["actor_hidden"], meta["action"]["dim"],
                  residual=meta["network"]["residual"])
    actor.load_state_dict(load_file(str(shipped_path())))
    obs = mission_observations()
    base = pol.residual_base.act(obs) if pol.residual_base is not None else None   # the default is residual
    with torch.no_grad():
        expected = actor(torch.from_numpy(with_base(obs, base))).numpy()
    got = pol.act(obs)
    assert got.dtype == np.float32 and got.shape == expected.shape
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-6)
    np.testing.assert_allclose(pol.act(obs[7]), expected[7], rtol=0, atol=1e-6)


def test_loading_and_acting_does_not_import_torch_nor_numba():
    # What the policy node's process holds: torch (~200 MB) and numba (~60 MB) stay out of it.
    import subprocess
    import sys
    code = ("import sys, numpy as np\n"
            "import cage_reactive_ddpg.nodes.policy_node\n"
            "from cage_reactive_ddpg.policy import load_policy\n"
            "p = load_policy()\n"
            "a = p.act(np.ones(p.layout.size, np.float32))\n"
            "assert a.shape == (1,)\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('torch', 'numba')))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]", f"torch or numba was imported: {out.stdout[:200]}"


def test_policy_for_another_sensor_profile_is_refused_naming_it(saved):
    _, wpath, mpath = saved
    meta = json.loads(mpath.read_text())
    meta["sensor_profile"] = "fls"
    mpath.write_text(json.dumps(meta))
    with pytest.raises(PolicyLoadError, match="trained for sensor profile 'fls', this sonar is profile 'study'"):
        load_policy(wpath, profile="study")
    assert load_policy(wpath, profile="fls").profile == "fls"


@pytest.mark.parametrize("name", ["policy", "policy_near", "policy_near_cleared"])
def test_shipped_driver_flies_straight_on_an_empty_scan_with_the_waypoint_dead_ahead(name):
    from cage_sim.controller import ArcController
    from cage_sim.shield import SafetyShield
    pol = load_policy(shipped_path().with_name(f"{name}.safetensors"))
    obs = open_water(pol, [0.0])[0]
    assert SafetyShield(pol, ArcController(pol.layout)).act(obs)[0] == 0.0
    assert abs(pol.act(obs)[0]) < 0.3            # the raw policy alone: within 6 deg of straight


def test_each_profile_has_a_shipped_driver_loaded_when_no_file_is_named():
    """``load_policy(profile=...)`` with no file (``policy_node sensor:=fls``, ``evaluate --sensor``):
    that profile's driver from ``DRIVERS``, one per sonar profile; an unknown profile names the known."""
    from cage_reactive_ddpg.policy import DRIVERS
    from cage_sim.sonar import PROFILE_NAMES
    assert sorted(DRIVERS) == sorted(PROFILE_NAMES)
    for profile, name in DRIVERS.items():
        pol = load_policy(profile=profile)
        assert pol.path.name == name and pol.profile == profile
    assert load_policy().path == load_policy(profile="study").path == shipped_path()
    with pytest.raises(PolicyLoadError, match="no shipped policy for sensor profile 'sidescan'.*fls"):
        load_policy(profile="sidescan")


@pytest.mark.parametrize("name, profile", [("policy_fls", "fls"), ("policy_fls_s54", "fls"), ("policy_fls_near", "fls"), ("policy_fls_near_s3", "fls"), ("policy_fls_near_cleared", "fls"),
                                           ("policy_mb360", "multibeam360"),
                                           ("policy_mb360_near", "multibeam360"),
                                           ("policy_scanning", "scanning"), ("policy_scanning_near", "scanning")])
def test_shipped_profile_policy_is_for_its_profile_only(name, profile):
    from cage_reactive_ddpg.policy import env_config_for
    path = shipped_path().with_name(f"{name}.safetensors")
    pol = load_policy(path, profile=profile)
    env = env_config_for(pol.metadata)
    assert pol.profile == profile and env.sonar.profile == profile and env.layout.size == pol.layout.size
    assert pol.act(np.zeros(pol.layout.size, np.float32)).shape == (1,)
    with pytest.raises(PolicyLoadError, match=f"trained for sensor profile '{profile}', this sonar is profile 'study'"):
        load_policy(path, profile="study")
    with pytest.raises(PolicyLoadError, match="name: file has 'cage-obs-v2', this build uses 'cage-obs-v1'"):
        load_policy(path, layout=EnvConfig().layout)          # a node building the study's observation


def test_the_recorded_sonar_is_the_one_evaluate_and_the_node_rebuild(saved):
    """A file's ``sonar`` record (every setting, written by the trainer since session 40) decides the
    sonar ``env_config_for`` builds, so a policy is flown on the beams it learnt on even after its
    profile's defaults change; without a record, the profile's defaults; a bad record is refused."""
    from cage_reactive_ddpg.policy import env_config_for
    from cage_sim.sonar import make_sonar
    _, _, mpath = saved
    meta = json.loads(mpath.read_text())
    assert "sonar" not in meta and env_config_for(meta).sonar == make_sonar("study")
    meta["config"] = {"sensor": "multibeam360"}
    assert env_config_for(meta).sonar == make_sonar("multibeam360")
    meta["sonar"] = make_sonar("multibeam360", beam_width_deg=5.0).to_dict()
    assert math.degrees(env_config_for(meta).sonar.beam_width) == pytest.approx(5.0)
    meta["sonar"]["dropout"] = 1.5
    with pytest.raises(PolicyLoadError, match="sonar record .* invalid: sonar.dropout: must be in"):
        env_config_for(meta)


@pytest.mark.parametrize("name, width", [("policy_mb360", 2.0), ("policy_mb360_cone5", 5.0),
                                         ("policy_mb360_guided", 5.0)])
def test_the_multibeam360_policies_record_the_beams_they_learnt_on(name, width):
    """The shipped ``policy_mb360`` learnt on today's 2 deg beams; the two that learnt on the 5 deg
    cones of multibeam360 before session 40 say so, and the evaluator flies them on those."""
    from cage_reactive_ddpg.policy import env_config_for
    from cage_sim.sonar import make_sonar
    assert math.degrees(make_sonar("multibeam360").beam_width) == pytest.approx(2.0)
    pol = load_policy(shipped_path().with_name(f"{name}.safetensors"), profile="multibeam360")
    assert math.degrees(env_config_for(pol.metadata).sonar.beam_width) == pytest.approx(width)


def test_sim_sonar_params_give_the_graph_the_recorded_sonar(saved):
    """What run_mission.sh passes to sim_node: the recorded profile and beams, and for a file without a
    record its profile's defaults, as ``env_config_for`` builds them; a missing file raises."""
    from cage_reactive_ddpg.policy import sim_sonar_params
    cone5 = shipped_path().with_name("policy_mb360_cone5.safetensors")
    assert sim_sonar_params(cone5) == ["sensor:=multibeam360", "n_beams:=72", "max_range:=20.0", "beam_width_deg:=5.0"]
    assert sim_sonar_params(saved[1])[0] == "sensor:=study" and "beam_width_deg:=0.0" in sim_sonar_params(saved[1])
    with pytest.raises(OSError):
        sim_sonar_params(saved[1].with_name("missing.safetensors"))
