"""Evaluate a policy (or the classical baseline) on N seeded episodes.

Missions are stepped in batches (one batched sonar call and one batched forward per step), but each
episode is fully determined by its scenario (``missions.episode_scenarios``), so the results are the
same as running them one by one, and the policy and the baseline meet the same episodes.

  evaluate --scenario study2d --episodes 1000 --seed 1 --policy baseline --json out.json --plot out.png
  evaluate --matrix sea --episodes 200 --seed 2026 --out docs/results/matrix_sea --plot docs/figures/matrix_sea.png

``--matrix`` (named in ``matrix.MATRICES`` or a YAML file) runs the raw policy, the shielded policy
and the classical baseline side by side on the same missions of every sea-condition cell and writes
a markdown table, a CSV and a JSON (``--out`` prefix) and a PNG (``--plot``), with 95 % Wilson intervals.
"""
from __future__ import annotations

import argparse
import filecmp
import json
import math
import sys
import textwrap
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Sequence

import numpy as np
from cage_sim.controller import REMEMBERED, ArcController, Policy
from cage_sim.mission import OUTCOMES, EnvConfig, Mission, noise_stream, observe_batch
from cage_sim.driver import DEFAULT_REMEMBERED, Driver, decide_batch, fallback_for, mission_moment
from cage_sim.route import ReplanWatch
from cage_sim.scenarios import Scenario
from cage_sim.shield import SafetyShield
from tqdm import tqdm

from .decision_trace import decision_row, write_trace
from .missions import PLANNERS, WaypointFn, episode_scenarios, waypoint_fn


@dataclass
class EpisodeResult:
    index: int
    outcome: str
    steps: int
    travelled: float
    route_length: float
    track: list = field(default_factory=list, repr=False)
    replans: int = 0
    late: str | None = None      # with a grace: how a timed-out mission ended, flown on past its budget


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """95 % Wilson score interval for k successes in n trials (sane at 0 % and 100 %). The interval
    always holds k / n; the bounds are clamped to it so that rounding (at k = 0 the lower bound
    came out 1e-19 for n = 500) never puts the rate outside its own interval."""
    if n == 0:
        return (0.0, 1.0)
    p = k / n
    den = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return (min(p, max(0.0, centre - half)), max(p, min(1.0, centre + half)))


def run_missions(policy: Policy, scenarios: list[Scenario], config: EnvConfig, batch: int = 250,
                 keep_tracks: int = 0, progress: bool = False, perception: bool = True,
                 replan: WaypointFn | None = None, grace: float = 0.0,
                 indices: Sequence[int] | None = None, known_map: bool = True,
                 trace: list[dict] | None = None) -> list[EpisodeResult]:
    """Run every scenario to its end; keep the tracks of the first ``keep_tracks`` episodes.

    ``perception``: the baseline and the shield see drift and moving returns (as in the graph);
    off = still-water rollouts against static returns (the drift-free shield, for comparison).
    ``replan``: plan a new route from the vehicle's pose when policy_node would ask for one
    (``ReplanWatch`` with its default parameters: no progress for 40 decisions, or 8 m off the
    route), flown from the decision that asked (policy_node holds that decision until the plan
    arrives); None = one plan per mission (the study's protocol).
    ``grace``: fly a mission that times out on, up to (1 + grace) x its budget, and record how it
    ended (``late``). Outcomes, steps and distances are still judged at the budget: each mission
    draws its own noise, so its flight up to the budget is the same with or without a grace.
    ``indices``: the episode index of each scenario, ascending (default: its position), what the
    results carry: a run of chosen missions reports them by their indices in the full set.
    ``known_map``: a shield keeps clear of each mission's known map too (``MapPoints``: its known
    obstacles and nominal net circle, what policy_node gets on the ``map`` topic).
    ``trace``: a list that gets one row per decision of every mission (``decision_trace``)."""
    if grace < 0 or not math.isfinite(grace):
        raise ValueError(f"grace: must be a finite number >= 0, got {grace}")
    index = list(indices) if indices is not None else list(range(len(scenarios)))
    if len(index) != len(scenarios):
        raise ValueError(f"indices: {len(index)} given for {len(scenarios)} scenarios")
    results: list[EpisodeResult] = []
    mapped = known_map and isinstance(policy, SafetyShield)    # only a shield reads the map
    bar = tqdm(total=len(scenarios), desc="episodes", disable=not progress, leave=False)
    for lo in range(0, len(scenarios), batch):
        ms = [Mission(sc, config) for sc in scenarios[lo:lo + batch]]
        noise = [noise_stream(sc) for sc in scenarios[lo:lo + batch]]   # per mission: batch-proof
        budgets = [m.max_steps for m in ms]
        for m in ms:
            m.max_steps = math.ceil((1.0 + grace) * m.max_steps)
        drivers = [Driver(policy, config.layout, config.vehicle, m.builder, perception,
                          m.map_points if mapped else None, config.sonar) for m in ms]
        watches = [ReplanWatch.defaults() for _ in ms] if replan is not None else None
        live = list(range(len(ms)))
        while live:
            obs = observe_batch(config, [ms[i] for i in live], [noise[i] for i in live])
            acts, shielded = decide_batch([drivers[i] for i in live], obs, [mission_moment(ms[i]) for i in live])
            still = []
            for i, a, flag in zip(live, acts, shielded):
                row = decision_row(ms[i], index[lo + i], a, flag) if trace is not None else None
                _, outcome = ms[i].step(float(np.clip(a, -1.0, 1.0)))
                if row is not None:
                    row["outcome"] = outcome or ""
                    trace.append(row)
                if outcome is None:
                    still.append(i)
                    if watches is not None:
                        replan_if_asked(ms[i], watches[i], replan)
                else:
                    results.append(_judged(ms[i], outcome, budgets[i], index[lo + i], lo + i < keep_tracks))
                    bar.update(1)
            live = still
    bar.close()
    return sorted(results, key=lambda r: r.index)


def _judged(m: Mission, outcome: str, budget: int, index: int, keep_track: bool) -> EpisodeResult:
    """A finished mission's result judged at its ``budget``; one that ended past it is a timeout
    there, and how it ended is kept as ``late``."""
    if m.steps <= budget:
        return EpisodeResult(index, outcome, m.steps, m.travelled, m.route_length,
                             list(m.track) if keep_track else [], m.replans)
    track = np.asarray(m.track[:budget + 1])
    travelled = float(np.hypot(*np.diff(track[:, :2], axis=0).T).sum())
    return EpisodeResult(index, "timeout", budget, travelled, m.route_length,
                         [tuple(p) for p in track] if keep_track else [], m.replans, late=outcome)


def replan_if_asked(m: Mission, watch: ReplanWatch, planner: WaypointFn) -> None:
    """policy_node's replan, offline: when ``watch`` asks, plan from the pose the vehicle has (the
    rrt_node plans from the latest odometry) to the goal and judge the rest against the new route.
    A failed plan keeps the old route (the planner counts its failures)."""
    if watch.update(m.tracker, m.x, m.y) is None:
        return
    wps = planner(replace(m.scenario, start=m.pose, waypoints=None))
    if wps is not None and len(wps):
        m.replan(wps)
        watch.reset()


def summarize(results: list[EpisodeResult], grace: float = 0.0) -> dict:
    """Counts, rates, 95 % intervals and means; with a ``grace``, how the timeouts ended past the
    budget (``late``: goal, collision, wander, or still a timeout)."""
    n = len(results)
    counts = {o: sum(r.outcome == o for r in results) for o in OUTCOMES}
    goals = [r for r in results if r.outcome == "goal"]
    return {
        "episodes": n,
        "counts": counts,
        "rates": {o: counts[o] / n if n else 0.0 for o in OUTCOMES},
        "ci95": {o: list(wilson(counts[o], n)) for o in OUTCOMES},
        "mean_steps": float(np.mean([r.steps for r in results])) if n else 0.0,
        "mean_steps_goal": float(np.mean([r.steps for r in goals])) if goals else None,
        "path_ratio_goal": float(np.mean([r.travelled / r.route_length for r in goals])) if goals else None,
        "replans": int(sum(r.replans for r in results)),
        **({"grace": grace, "late": {o: sum(r.late == o for r in results) for o in OUTCOMES}} if grace else {}),
    }


def failed_episodes(results: list[EpisodeResult]) -> list[dict]:
    """Index, outcome and decisions of every episode that did not reach the goal: the missions to
    look at again (``--failures`` plots them; an index re-creates its mission from the seed)."""
    return [{"index": r.index, "outcome": r.outcome, "steps": r.steps, **({"late": r.late} if r.late else {})}
            for r in results if r.outcome != "goal"]


def plot_failures(path: str | Path, scenarios: list[Scenario], results: list[EpisodeResult], title: str,
                  n: int = 12) -> int:
    """The tracks of up to ``n`` episodes that did not reach the goal (``plot_tracks``), or no file
    when every episode did; returns how many failed."""
    failed = [r for r in results if r.outcome != "goal"]
    if failed:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        head = f"{len(failed)} not at the goal" + (f" (the first {n})" if len(failed) > n else "")
        plot_tracks(path, scenarios, failed, textwrap.fill(f"{title}: {head}", 40 * min(3, len(failed))), n=n)
    return len(failed)


def table(name: str, s: dict) -> str:
    lines = [f"{name}: {s['episodes']} episodes",
             f"  {'outcome':<10}{'count':>7}{'rate':>9}   95% CI"]
    for o in OUTCOMES:
        lo, hi = s["ci95"][o]
        lines.append(f"  {o:<10}{s['counts'][o]:>7}{100 * s['rates'][o]:>8.1f}%   [{100 * lo:.1f}, {100 * hi:.1f}]")
    lines.append(f"  mean steps {s['mean_steps']:.1f}; goal episodes: mean steps "
                 f"{_fmt(s['mean_steps_goal'])}, path / route length {_fmt(s['path_ratio_goal'], '.3f')}")
    if s.get("failed"):
        shown = s["failed"][:20]
        lines.append("  not at the goal: " + ", ".join(f"{f['index']} ({f['outcome']})" for f in shown)
                     + (f", ... ({len(s['failed'])} in all)" if len(s["failed"]) > len(shown) else ""))
    if "late" in s:
        late = s["late"]
        lines.append(f"  flown on to {1 + s['grace']:g} x the budget, the {s['counts']['timeout']} timeouts end: "
                     + ", ".join(f"{late[o]} {o}" for o in OUTCOMES if o != "timeout")
                     + f", {late['timeout']} still timeout")
    if s.get("planner_failures"):
        lines.append(f"  planner failures (flown straight): {s['planner_failures']}")
    if "shield_decisions" in s:
        lines.append(f"  safety shield: overrode {s['shield_interventions']} of {s['shield_decisions']} decisions "
                     f"({s.get('shield_approaches', 0)} of them an approach to the goal: the controller's or the "
                     f"goal search's, "
                     f"{s.get('shield_recoveries', 0)} flown by the controller for a policy making no progress)")
    return "\n".join(lines)


def _fmt(v, spec: str = ".1f") -> str:
    return "-" if v is None else format(v, spec)


def plot_tracks(path: str | Path, scenarios: list[Scenario], results: list[EpisodeResult],
                title: str = "", n: int = 9) -> None:
    """A grid of episodes (world, route, track coloured by outcome), like the study's path figures."""
    import matplotlib.pyplot as plt
    from cage_sim.plotting import draw_track, draw_world
    shown = [r for r in results if r.track][:n]
    cols = min(3, len(shown)) or 1
    rows = max(1, math.ceil(len(shown) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 4.2 * rows), squeeze=False)
    for ax in axes.flat:
        ax.set_visible(False)
    for ax, r in zip(axes.flat, shown):
        ax.set_visible(True)
        sc = scenarios[r.index]
        draw_world(ax, sc.world)
        route = np.vstack([np.asarray(sc.start[:2])[None], sc.route()])
        ax.plot(route[:, 0], route[:, 1], "--", color="tab:blue", lw=0.8)
        draw_track(ax, r.track, r.outcome)
        ax.plot(*sc.start[:2], "k^", ms=7)
        ax.plot(*sc.goal, "r*", ms=11)
        ax.set_title(f"episode {r.index}: {r.outcome} ({r.steps} steps)", fontsize=9)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


#: The drivers whose perception ``--remembered`` sets (a raw policy reads its observation; a raw
#: residual policy's base keeps the setting it was trained with).
READS_REMEMBERED = ("shield", "baseline")


def remembered_record(a: argparse.Namespace, drivers) -> dict:
    """``{"remembered": ...}`` for the summary and matrix files of a run that flies a shield or the
    baseline with another setting than "all", else {}: files from before the setting existed (all
    "all") and raw runs then read alike."""
    return {"remembered": a.remembered} if a.remembered != "all" and set(drivers) & set(READS_REMEMBERED) else {}


def load_driver(spec: str | None, shield: bool = True, sensor: str | None = None,
                remembered: str = DEFAULT_REMEMBERED):
    """``baseline`` -> ArcController (over the ``sensor`` profile's scan); else a policy file (None =
    the shipped one), behind the safety shield unless ``shield`` is off (as the policy node runs it).
    ``remembered``: which remembered returns the baseline's or the shield's perception counts."""
    if spec == "baseline":
        return (ArcController(EnvConfig(sonar=sensor or "study").layout, remembered=remembered),
                "baseline (ArcController)", None)
    from .policy import load_policy
    pol = load_policy(spec, profile=sensor)
    if shield:
        return SafetyShield(pol, fallback_for(pol, pol.layout, remembered=remembered)), f"policy {pol.path} + shield", \
            pol.metadata
    return pol, f"policy {pol.path}", pol.metadata


def driver_env(meta: dict | None, a: argparse.Namespace) -> EnvConfig:
    """The policy's own training EnvConfig (sensor, observation, motion), or for the baseline alone
    the study's v1 with ``--sensor``."""
    from .policy import env_config_for
    if meta:
        return env_config_for(meta, a.motion)
    return EnvConfig(motion=a.motion or "continuous", sonar=a.sensor or "study")


def evaluate(driver: Policy, scenario: str, episodes: int, seed: int, motion: str = "continuous",
             planner: str = "none", keep_tracks: int = 9, progress: bool = False, env: EnvConfig | None = None,
             replan: bool = False, grace: float = 0.0, only: "list[int] | None" = None, known_map: bool = True,
             trace: list[dict] | None = None):
    """(summary dict, scenarios, results) for ``episodes`` seeded episodes; ``replan``: new plans
    under way as in the graph (``run_missions``), with the same planner; ``known_map``: see
    ``run_missions``; ``trace``: see ``run_missions``. ``only``: just these
    episodes of the set (each the very mission of the full run); the scenarios come back as
    {index: scenario} then."""
    routes = waypoint_fn(planner)
    env = env or EnvConfig(motion=motion)
    only = sorted(only) if only else None
    if only:
        scs = {i: episode_scenarios(scenario, 1, seed, routes, start=i)[0] for i in only}
        flown = list(scs.values())
    else:
        scs = flown = episode_scenarios(scenario, episodes, seed, routes)
    res = run_missions(driver, flown, env, keep_tracks=len(flown) if only else keep_tracks, progress=progress,
                       replan=replan_planner(routes, replan), grace=grace, indices=only, known_map=known_map,
                       trace=trace)
    summary = summarize(res, grace)
    # Missions whose plan failed fly the straight line: say how many, never hide it.
    summary["planner_failures"] = len(getattr(routes, "failures", []))
    return summary, scs, res


def output_paths(prefix: Path) -> dict[str, Path]:
    """The matrix's .md, .csv and .json for ``--out PREFIX``. A prefix may hold dots (``runs/p0.5``
    -> ``runs/p0.5.md``); one ending in one of the three suffixes names the set (``m.json`` -> ``m.*``)."""
    stem = prefix.with_suffix("") if prefix.suffix in (".md", ".csv", ".json") else prefix
    return {ext: stem.parent / (stem.name + ext) for ext in (".md", ".csv", ".json")}


def replan_planner(routes: WaypointFn | None, replan: bool) -> WaypointFn | None:
    """The planner that replans under way: the mission's own (``--planner rrt``), else none."""
    if replan and routes is None:
        raise ValueError("--replan on: needs a planner (--planner rrt) to plan the new routes")
    return routes if replan else None


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenario", default="study2d", help="scenario name, YAML file, or mix a:0.5,b:0.5")
    ap.add_argument("--episodes", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=12345)
    ap.add_argument("--policy", default=None, help="policy file (.safetensors/.json), 'baseline'; default: shipped")
    ap.add_argument("--motion", default=None, choices=["continuous", "study"],
                    help="vehicle step (default: the policy's training motion; continuous for the baseline)")
    ap.add_argument("--planner", default="none", choices=list(PLANNERS),
                    help="route: none = straight to the goal, rrt = the global planner, rrt_current = it on the net "
                         "wall the mean current pushes in, dense = straight every 1 m")
    ap.add_argument("--shield", default="on", choices=["on", "off"],
                    help="run a policy behind the safety shield, as the policy node does (default on)")
    ap.add_argument("--known-map", default="on", choices=["on", "off"],
                    help="the shield keeps clear of the mission's known map (known obstacles, nominal net circle) "
                         "beside the sonar's returns, as policy_node does with the map topic (default on; off: "
                         "the returns alone, the shield before session 45)")
    ap.add_argument("--remembered", default=DEFAULT_REMEMBERED, choices=list(REMEMBERED),
                    help="which remembered returns the shield and the baseline count beside the scan: cleared "
                         "(default since session 53: those outside the scan's field of view that the sonar has "
                         "not since seen past nor the vehicle passed through), out_of_view (those outside the "
                         "field of view; session 52), or all (every one, the default before session 53); none "
                         "beside a 360 deg scan with cleared and out_of_view; as policy_node's remembered_returns")
    ap.add_argument("--replan", default="off", choices=["off", "on"],
                    help="on: ask for a new plan under way when policy_node would (40 decisions without "
                         "progress, 8 m off the route), as the node graph does; off: one plan per mission")
    ap.add_argument("--json", default=None, help="write the summary here")
    ap.add_argument("--plot", default=None, help="PNG of several episodes' tracks")
    ap.add_argument("--failures", default=None,
                    help="PNG of the tracks of (up to 12) episodes that did not reach the goal; with --matrix a "
                         "prefix: one PNG per cell and driver with failures, PREFIX_cell<K>_<driver>.png")
    ap.add_argument("--only", default=None,
                    help="fly just these missions of the set (e.g. 66,616 or 10-19: indices below --episodes, as "
                         "--failures lists them), each the very mission of the full run; with --matrix in every "
                         "cell run (use --cells); --plot then shows their tracks")
    ap.add_argument("--quiet", action="store_true")
    ap.add_argument("--sensor", default=None,
                    help="sonar profile: with no --policy, the profile's shipped driver flies (policy.DRIVERS), "
                         "and the baseline alone reads that profile's scan; a policy file must be of this profile "
                         "(else refused, naming both; without --sensor it uses the one it was trained with)")
    ap.add_argument("--matrix", default=None, help="sea-condition matrix: a name (sea, sea_small, tiny, strong) or a YAML file")
    ap.add_argument("--drivers", default="raw,shield,baseline",
                    help="with --matrix: which of raw, shield, baseline to run (comma-separated)")
    ap.add_argument("--out", default=None, help="with --matrix: output prefix for .md/.csv/.json "
                                                "(default out/matrix_<name>)")
    ap.add_argument("--reuse", default=None,
                    help="with --matrix: JSONs (comma-separated) written by earlier --matrix runs with the same "
                         "matrix, seed, episodes, planner and sensor; their rows (cell, driver) are reused, "
                         "not run again (the first file's row wins)")
    ap.add_argument("--cells", default=None,
                    help="with --matrix: only these cells (indices, e.g. 0-3,6); each keeps its own missions, so "
                         "parts run in separate processes merge with --reuse into the whole matrix")
    ap.add_argument("--grace", type=float, default=0.0,
                    help="fly a mission that times out on, up to (1 + GRACE) x its budget, and report how the "
                         "timeouts end (late goals); outcomes are still judged at the budget (default 0: off)")
    ap.add_argument("--trace", default=None,
                    help="CSV with one row per decision of every mission flown (pose, waypoint, distance to the "
                         "goal, clearance, action, whether the shield replaced it, the goal in sight, replans, "
                         "outcome); with --matrix, cell and driver too. Use with --only (about 100 rows a mission)")
    a = ap.parse_args(argv)
    if a.matrix:
        return matrix_main(a)
    try:   # a missing or mismatched policy, a bad scenario: one clear line, no traceback
        driver, name, meta = load_driver(a.policy, a.shield == "on", a.sensor, a.remembered)
        env = driver_env(meta, a)
        motion = env.motion
        only = parse_only(a)
        trace: list[dict] | None = [] if a.trace else None
        summary, scs, res = evaluate(driver, a.scenario, a.episodes, a.seed, motion, a.planner,
                                     keep_tracks=a.episodes if a.failures else 9 if a.plot else 0,
                                     progress=not a.quiet, env=env,
                                     replan=a.replan == "on", grace=a.grace, only=only,
                                     known_map=a.known_map == "on", trace=trace)
        if trace is not None:
            write_trace(trace, a.trace)
    except (ValueError, OSError, RuntimeError) as err:   # PolicyLoadError is a RuntimeError
        print(f"evaluate: {err}", file=sys.stderr)
        return 2
    summary.update(driver=name, scenario=a.scenario, seed=a.seed, motion=motion, planner=a.planner, replan=a.replan,
                   known_map=a.known_map, failed=failed_episodes(res), **({"only": only} if only else {}),
                   **remembered_record(a, ["shield" if a.shield == "on" else "baseline" if a.policy == "baseline"
                                           else "raw"]))
    if isinstance(driver, SafetyShield):
        summary.update(shield_interventions=driver.interventions, shield_decisions=driver.decisions,
                       shield_approaches=driver.approaches, shield_recoveries=driver.recoveries)
    print(table(f"{name} on {a.scenario} (seed {a.seed}, motion {motion}, planner {a.planner}, replan {a.replan})",
                summary))
    if a.json:
        Path(a.json).write_text(json.dumps(summary, indent=2))
    if a.plot:
        plot_tracks(a.plot, scs, res, f"{name} on {a.scenario}")
    if a.failures:
        plot_failures(a.failures, scs, res, f"{name} on {a.scenario}")
    return 0


def parse_only(a: argparse.Namespace) -> list[int] | None:
    """``--only``'s mission indices (below ``--episodes``), or None for the whole set."""
    from .matrix import parse_cells
    if not a.only:
        return None
    if a.reuse:
        raise ValueError("--only: a run of chosen missions is not merged with --reuse (its rows are not whole cells)")
    return sorted(parse_cells(a.only, a.episodes, "--only", "the missions of --episodes"))


# A matrix file's ``policy`` key: the --policy named, or SHIPPED_LABEL, then what a merge adds
# (MERGED_FROM ...). Written by ``matrix_main``, read back by ``_policy_flown``.
SHIPPED_LABEL = "shipped policy"
MERGED_FROM = " (rows of "


def _policy_flown(recorded: str | None) -> str:
    """The weights file a matrix file's policy rows came from, as a resolved path: the ``policy``
    key without what a merge adds; ``SHIPPED_LABEL`` is the package's default."""
    from .policy import shipped_path
    text = (recorded or SHIPPED_LABEL).split(MERGED_FROM)[0]
    return str((shipped_path() if text == SHIPPED_LABEL else Path(text)).resolve())


def _same_weights(a: str, b: str) -> bool:
    """The same path, or two files with the same bytes (weights copied from a run folder into
    ``weights/`` after their matrix ran)."""
    pa, pb = Path(a), Path(b)
    return a == b or (pa.is_file() and pb.is_file() and filecmp.cmp(pa, pb, shallow=False))


def _reused(a: argparse.Namespace, name: str, motion: str, sensor: str, observation: dict) -> list[dict]:
    """Rows of earlier runs of the same matrix on the same missions (``--reuse A.json[,B.json]``), checked.
    The observation layout is checked where the file records it (files before session 25 do not).
    Raw or shield rows taken from a file must be the policy's named here (the same weights file,
    or its bytes): merged without ``--policy``, another policy's rows once went out under the
    default's name (session 48). A file's rows for cells and drivers already taken are skipped."""
    unrecorded = {"replan": "off", "observation": observation,    # what a file too old to record the key ran with
                  "known_map": "off", "remembered": "all"}
    rows: list[dict] = []
    flying = _policy_flown(a.policy)                             # this run's weights, resolved once
    for path in filter(None, (a.reuse or "").split(",")):
        old = json.loads(Path(path).read_text())
        keys = [("matrix", name), ("seed", a.seed), ("episodes", a.episodes), ("planner", a.planner),
                ("motion", motion), ("sensor", sensor), ("replan", a.replan), ("observation", observation)]
        if any(r["driver"] == "shield" for r in old["rows"]):   # the map changes only the shield's rows
            keys.append(("known_map", a.known_map))
        if any(r["driver"] in READS_REMEMBERED for r in old["rows"]):
            keys.append(("remembered", a.remembered))
        for key, mine in keys:
            if old.get(key, unrecorded.get(key)) != mine:
                raise ValueError(f"--reuse {path}: {key} is {old.get(key)!r} there, {mine!r} here")
        have = {(r["cell"], r["driver"]) for r in rows}
        taken = [r for r in old["rows"] if (r["cell"], r["driver"]) not in have]
        theirs = _policy_flown(old.get("policy"))
        if any(r["driver"] != "baseline" for r in taken) and not _same_weights(theirs, flying):
            raise ValueError(f"--reuse {path}: its policy rows are {theirs}'s, this run's policy is {flying} "
                             f"(name it with --policy)")
        rows += taken
    return rows


def matrix_main(a: argparse.Namespace) -> int:
    """``--matrix``: every chosen driver on every cell; tables, CSV, JSON and PNG."""
    from . import matrix as mx
    try:
        name, cells = mx.load_matrix(a.matrix)
        wanted = [d.strip() for d in a.drivers.split(",") if d.strip()]
        bad = sorted(set(wanted) - {"raw", "shield", "baseline"})
        if bad:
            raise ValueError(f"--drivers: unknown {bad} (raw, shield, baseline)")
        if a.policy is None and a.sensor not in (None, "study") and set(wanted) - {"baseline"}:
            from .policy import shipped_path
            a.policy = str(shipped_path(a.sensor))   # the profile's driver, named so in the files (and --reuse)
        drivers, meta = {}, None
        for d in wanted:
            if d != "baseline":
                drivers[d], _, meta = load_driver(a.policy, shield=(d == "shield"), sensor=a.sensor,
                                                  remembered=a.remembered)
        own_sonar = a.policy == "baseline" or (a.policy is None and a.sensor is not None)
        if meta is None and not own_sonar:
            # The baseline alone still reads the policy's scan, memory and velocity: rows of one
            # matrix run in parts (``--drivers baseline`` here, ``raw,shield`` there) must compare
            # like with like. Only ``--policy baseline``, or ``--sensor`` with no policy named,
            # gives it that sonar's plain scan (as ``--sensor``'s help says).
            _, _, meta = load_driver(a.policy, shield=False, sensor=a.sensor)
        env = driver_env(meta, a)
        if "baseline" in wanted:
            drivers["baseline"] = ArcController(env.layout, remembered=a.remembered)   # the policy's scan and memory
        motion = env.motion
        old = _reused(a, name, motion, env.sonar.profile, env.layout.to_dict())
        wanted_cells = set(mx.parse_cells(a.cells, len(cells)))
        only = parse_only(a)
        skip = {(r["cell"], r["driver"]) for r in old} | {(k, d) for k in range(len(cells)) if k not in wanted_cells
                                                          for d in drivers}
        trace: list[dict] | None = [] if a.trace else None
        rows = mx.run_matrix(cells, drivers, a.episodes, a.seed, a.planner, env, progress=not a.quiet,
                             replan=a.replan == "on", skip=skip, grace=a.grace, failures=a.failures, only=only,
                             known_map=a.known_map == "on", trace=trace)
        if trace is not None:
            write_trace(trace, a.trace)
        order = {d: i for i, d in enumerate(["raw", "shield", "baseline"])}
        rows = sorted(rows + old, key=lambda r: (r["cell"], order.get(r["driver"], 9)))
    except (ValueError, OSError, RuntimeError) as err:
        print(f"evaluate: {err}", file=sys.stderr)
        return 2
    flown = {r["driver"] for r in rows}          # this run's and the merged files' drivers
    prefix = Path(a.out or f"out/matrix_{name}")
    prefix.parent.mkdir(parents=True, exist_ok=True)
    policy = str(a.policy or SHIPPED_LABEL)
    if a.reuse:
        policy += f"{MERGED_FROM}{sorted({r['driver'] for r in old})} from {a.reuse})"
    per_cell = f"missions {a.only} of {a.episodes}" if only else f"{a.episodes} missions"
    title = (f"matrix {name}: sensor {env.sonar.profile}, {per_cell} per cell, seed {a.seed}, "
             f"planner {a.planner}, replan {a.replan}, known map {a.known_map}, policy {Path(str(a.policy or 'policy.safetensors (shipped)')).name}"
             + (f", late goals within {1 + a.grace:g} x the budget" if a.grace else "")
             + (f", remembered returns {a.remembered}" if remembered_record(a, flown) else ""))
    md = mx.markdown(rows, title)
    print(md)
    out = output_paths(prefix)
    out[".md"].write_text(md)
    mx.write_csv(rows, out[".csv"])
    out[".json"].write_text(json.dumps(
        {"matrix": name, "episodes": a.episodes, "seed": a.seed, "planner": a.planner, "motion": motion,
         "sensor": env.sonar.profile, "replan": a.replan, "known_map": a.known_map, "observation": env.layout.to_dict(),
         "policy": policy, "grace": a.grace, **({"only": only} if only else {}),
         **remembered_record(a, flown), "rows": rows}, indent=1))
    if a.plot:
        Path(a.plot).parent.mkdir(parents=True, exist_ok=True)
        mx.plot(rows, a.plot, title)
    return 0


if __name__ == "__main__":
    sys.exit(main())
