"""The evaluator: counts add up, same seeds give the same episodes, Wilson intervals, CLI output."""
import json

import numpy as np
import pytest
from cage_sim.sonar import make_sonar

from cage_reactive_ddpg.evaluate import evaluate, main, wilson
from cage_reactive_ddpg.missions import episode_scenarios, parse_mix
from cage_reactive_ddpg.policy import shipped_path


class Straight:
    def act(self, obs):
        obs = np.asarray(obs)
        return np.clip(obs[..., -1:] * 9.0, -1, 1)     # steer at the waypoint, ignore the sonar


def test_outcome_counts_add_up():
    s, scs, res = evaluate(Straight(), "study2d", 40, seed=3)
    assert sum(s["counts"].values()) == s["episodes"] == len(res) == 40
    assert abs(sum(s["rates"].values()) - 1.0) < 1e-9
    assert [r.index for r in res] == list(range(40))
    for o, (lo, hi) in s["ci95"].items():
        assert lo <= s["rates"][o] <= hi


def test_same_seed_same_episodes_whatever_the_batching():
    a = episode_scenarios("study2d:0.5,cage:0.5", 6, seed=7)
    b = episode_scenarios("study2d:0.5,cage:0.5", 3, seed=7, start=3)
    assert [s.to_dict() for s in a[3:]] == [s.to_dict() for s in b]
    s1, _, r1 = evaluate(Straight(), "study2d", 12, seed=5)
    from cage_reactive_ddpg.evaluate import run_missions
    from cage_sim.mission import EnvConfig
    r2 = run_missions(Straight(), episode_scenarios("study2d", 12, 5), EnvConfig(), batch=5)
    assert [(r.outcome, r.steps) for r in r1] == [(r.outcome, r.steps) for r in r2]
    assert parse_mix("a:0.7,b:0.3") == [("a", 0.7), ("b", 0.3)] and parse_mix("study2d") == [("study2d", 1.0)]


class ScanFollower:
    """Steers by a smooth function of the whole observation, so any change of noise moves its track."""

    def act(self, obs):
        obs = np.nan_to_num(np.asarray(obs, dtype=np.float64), posinf=2.0)
        return np.clip(np.sin(obs.sum(axis=-1, keepdims=True)), -1, 1)


@pytest.mark.parametrize("sensor", ["fls", "scanning"])
def test_a_noisy_mission_flies_the_same_alone_as_in_its_batch(sensor):
    """Each mission draws its sonar noise from its own stream (``noise_stream``): a failed mission
    of a noisy profile can be flown again alone, and gives the same track as in the matrix's batch."""
    from cage_reactive_ddpg.evaluate import run_missions
    from cage_sim.mission import EnvConfig
    config = EnvConfig(sonar=sensor)
    scs = episode_scenarios("cage", 5, seed=11)
    batch = run_missions(ScanFollower(), scs, config, keep_tracks=5)
    alone = [run_missions(ScanFollower(), [sc], config, keep_tracks=1)[0] for sc in scs]
    assert [r.track for r in batch] == [r.track for r in alone]
    clean = EnvConfig(sonar=make_sonar(sensor, noise_std=0.0, dropout=0.0))
    assert run_missions(ScanFollower(), scs[:1], clean, keep_tracks=1)[0].track != batch[0].track


def test_a_grace_flies_timeouts_on_and_still_judges_at_the_budget():
    """``grace``: missions that time out fly on to (1 + grace) x their budget and say how they ended
    (``late``); every outcome, step count and distance is still the one judged at the budget."""
    from cage_reactive_ddpg.evaluate import run_missions, summarize
    from cage_sim.mission import EnvConfig
    config = EnvConfig(max_steps_factor=0.9, max_steps_extra=0)     # too short for most routes
    scs = episode_scenarios("study2d", 16, seed=4)
    plain = run_missions(Straight(), scs, config)
    graced = run_missions(Straight(), scs, config, grace=1.0)
    assert [(r.outcome, r.steps) for r in plain] == [(r.outcome, r.steps) for r in graced]
    assert [r.travelled for r in graced] == pytest.approx([r.travelled for r in plain])
    timeouts = [r for r in graced if r.outcome == "timeout"]
    assert timeouts and all(r.late in ("goal", "collision", "wander", "timeout") for r in timeouts)
    assert all(r.late is None for r in graced if r.outcome != "timeout")
    assert all(r.late is None for r in plain)
    s = summarize(graced, 1.0)
    assert s["late"]["goal"] > 0 and sum(s["late"].values()) == s["counts"]["timeout"]
    assert "late" not in summarize(plain)
    with pytest.raises(ValueError, match="grace: must be a finite number >= 0"):
        run_missions(Straight(), scs, config, grace=-1.0)


def test_cli_grace_counts_late_goals_in_the_matrix(tmp_path):
    prefix = tmp_path / "m"
    args = ["--matrix", "tiny", "--episodes", "2", "--seed", "5", "--policy", "baseline", "--drivers", "baseline",
            "--quiet"]
    assert main(args + ["--out", str(tmp_path / "plain")]) == 0
    assert main(args + ["--grace", "1", "--out", str(prefix)]) == 0
    rows = json.loads(prefix.with_suffix(".json").read_text())["rows"]
    plain = json.loads((tmp_path / "plain.json").read_text())["rows"]
    assert all(0 <= r["late_goal"] <= r["timeout"] for r in rows)
    assert [{k: v for k, v in r.items() if k != "late_goal"} for r in rows] == plain
    assert "baseline: late goals" in prefix.with_suffix(".md").read_text()


def test_wilson_interval():
    lo, hi = wilson(0, 100)
    assert lo == 0.0 and 0.03 < hi < 0.04
    lo, hi = wilson(90, 100)
    assert 0.82 < lo < 0.83 and 0.94 < hi < 0.95
    # the rate lies inside its own interval for every count (rounding once put the lower bound at
    # 1e-19 for 0 of 500, and the matrix plot refused the negative error bar)
    assert all(wilson(k, n)[0] <= k / n <= wilson(k, n)[1] for n in range(1, 1201) for k in range(n + 1))


def test_cli_baseline_json_and_plot(tmp_path, capsys):
    out, png = tmp_path / "e.json", tmp_path / "e.png"
    assert main(["--scenario", "study2d", "--episodes", "10", "--seed", "1", "--policy", "baseline",
                 "--json", str(out), "--plot", str(png), "--quiet"]) == 0
    s = json.loads(out.read_text())
    assert s["episodes"] == 10 and sum(s["counts"].values()) == 10 and png.stat().st_size > 1000
    assert "goal" in capsys.readouterr().out


def test_cli_refuses_bad_policy_file(tmp_path, capsys):
    assert main(["--policy", str(tmp_path / "missing.safetensors"), "--episodes", "2", "--quiet"]) == 2
    assert "not found" in capsys.readouterr().err


def test_cli_bad_input_is_one_clear_line(capsys, tmp_path):
    from cage_reactive_ddpg import evaluate as ev
    from cage_reactive_ddpg import train as tr
    assert ev.main(["--scenario", "nope", "--episodes", "1", "--quiet"]) == 2
    assert "scenario: 'nope'" in capsys.readouterr().err
    assert ev.main(["--policy", str(tmp_path / "missing.safetensors"), "--episodes", "1", "--quiet"]) == 2
    assert "not found" in capsys.readouterr().err
    assert tr.main(["--scenario", "nope", "--steps", "10", "--out", str(tmp_path / "run"), "--quiet"]) == 2
    assert "scenario: 'nope'" in capsys.readouterr().err


class Constant:
    def __init__(self, a: float):
        self.a = a

    def act(self, obs):
        return np.full((1,) if np.ndim(obs) == 1 else (len(obs), 1), self.a, dtype=np.float32)


def test_replan_under_way_judges_the_rest_against_the_new_route():
    """A route the long way round (north, then back south) and a vehicle that flies straight east:
    without replans it is judged a wander 15 m off the first leg; with them, policy_node's trigger
    (8 m off the route) plans again from where the vehicle is, and the new straight route ends at the goal."""
    from cage_reactive_ddpg.evaluate import run_missions
    from cage_sim.mission import EnvConfig
    from cage_sim.scenarios import Scenario
    from cage_sim.world import World
    sc = Scenario("detour", World(30.0), (-20.0, 0.0, 0.0), (20.0, 0.0), ((0.0, 18.0), (20.0, 0.0)))
    asked = []

    def planner(s):
        asked.append(s.start)
        return [s.goal]

    once = run_missions(Constant(0.0), [sc], EnvConfig())[0]
    again = run_missions(Constant(0.0), [sc], EnvConfig(), replan=planner)[0]
    assert once.outcome == "wander" and once.replans == 0
    assert again.outcome == "goal" and again.replans == len(asked) == 1
    x, y, _ = asked[0]
    assert -20.0 < x < 0.0 and abs(y) < 1e-6            # planned from the vehicle's pose, on its line


def test_cli_replan_needs_a_planner(capsys):
    assert main(["--scenario", "study2d", "--episodes", "2", "--replan", "on", "--quiet"]) == 2
    assert "--replan on: needs a planner" in capsys.readouterr().err


def test_cli_failures_lists_and_plots_the_missions_that_missed(tmp_path, capsys):
    """``--failures``: the episodes that did not reach the goal, by index (the JSON, the table) and as a
    PNG of their tracks; a run with none writes no PNG. A still-water policy in a 0.5 m/s current
    with schools collides in about half its missions (graph-checked: bench_agreement_schools_s41)."""
    calm = str(shipped_path().with_name("policy_calm.safetensors"))
    out, png = tmp_path / "f.json", tmp_path / "f.png"
    assert main(["--scenario", "cage?current=0.5&obstacles=small&schools=3", "--episodes", "8", "--seed", "3",
                 "--policy", calm, "--shield", "off", "--json", str(out), "--failures", str(png), "--quiet"]) == 0
    s = json.loads(out.read_text())
    failed = s["failed"]
    assert len(failed) == 8 - s["counts"]["goal"] > 0
    assert sorted(f["outcome"] for f in failed) == sorted(o for o in s["counts"] for _ in range(s["counts"][o])
                                                          if o != "goal")
    assert png.stat().st_size > 1000
    assert "not at the goal: " + f"{failed[0]['index']} ({failed[0]['outcome']})" in capsys.readouterr().out
    none = tmp_path / "none.png"
    assert main(["--scenario", "study2d", "--episodes", "3", "--seed", "1", "--policy", "baseline",
                 "--failures", str(none), "--quiet"]) == 0
    assert not none.exists() and "not at the goal" not in capsys.readouterr().out


def test_cli_only_flies_the_very_missions_of_the_full_run(tmp_path, capsys):
    """``--only``: the chosen missions, each the same mission (and outcome, to the decision) as in
    the full run, reported by their indices; an index outside the set is refused naming the flag."""
    calm = str(shipped_path().with_name("policy_calm.safetensors"))
    args = ["--scenario", "cage?current=0.5&obstacles=small&schools=3", "--episodes", "8", "--seed", "3",
            "--policy", calm, "--shield", "off", "--quiet"]
    full, part = tmp_path / "full.json", tmp_path / "part.json"
    assert main(args + ["--json", str(full)]) == 0
    failed = json.loads(full.read_text())["failed"]
    chosen = sorted({failed[0]["index"], 0, 7})
    png = tmp_path / "part.png"
    assert main(args + ["--json", str(part), "--only", ",".join(map(str, reversed(chosen))), "--plot", str(png)]) == 0
    s = json.loads(part.read_text())
    assert s["only"] == chosen and s["episodes"] == len(chosen) and png.stat().st_size > 1000
    assert [f for f in failed if f["index"] in chosen] == s["failed"]
    capsys.readouterr()
    assert main(args + ["--only", "8"]) == 2
    assert "--only: '8' is outside the missions of --episodes 0-7" in capsys.readouterr().err


def test_cli_trace_is_the_flight_the_summary_counts(tmp_path):
    """``--trace``: one row per decision of every mission flown, in order; the last row of each
    carries its outcome (the summary's counts), the flagged rows are the shield's interventions, and
    re-flying the traced actions through a fresh mission gives the traced poses and outcome."""
    import argparse
    import csv
    import math

    from cage_sim.mission import Mission

    from cage_reactive_ddpg.evaluate import driver_env, load_driver
    spec, seed = "cage?current=0.5&obstacles=small&schools=3", 3
    trace, out = tmp_path / "trace.csv", tmp_path / "s.json"
    assert main(["--scenario", spec, "--episodes", "4", "--seed", str(seed), "--only", "1,2", "--quiet",
                 "--json", str(out), "--trace", str(trace)]) == 0
    s = json.loads(out.read_text())
    rows = list(csv.DictReader(trace.open()))
    by = {e: [r for r in rows if int(r["episode"]) == e] for e in (1, 2)}
    assert len(rows) == sum(len(v) for v in by.values()) and all(by.values())
    outcomes = [v[-1]["outcome"] for v in by.values()]
    assert sorted(outcomes) == sorted(o for o, n in s["counts"].items() for _ in range(n))
    assert all(r["outcome"] == "" for v in by.values() for r in v[:-1])
    assert sum(int(r["shielded"]) for r in rows) == s["shield_interventions"]
    _, _, meta = load_driver(None)
    env = driver_env(meta, argparse.Namespace(motion=None, sensor=None))
    for e, v in by.items():
        assert [int(r["decision"]) for r in v] == list(range(len(v)))
        m = Mission(episode_scenarios(spec, 1, seed, start=e)[0], env)
        for r in v:
            assert (m.x, m.y) == pytest.approx((float(r["x"]), float(r["y"])), abs=1e-3)
            assert math.degrees(m.yaw) == pytest.approx(float(r["yaw_deg"]), abs=1e-2)
            _, outcome = m.step(float(r["action"]))
        assert outcome == v[-1]["outcome"]
