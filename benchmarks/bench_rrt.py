#!/usr/bin/env python3
"""Benchmark of the global planner against the source study's Table 3, plus 1000 random queries.

Part 1 (Table 3): the 30 m cage with 20 random 2 x 2 m known squares (``generate_cage``), RRT at
max step 3, 7 and 12 m, ``--runs`` cages each (the scenario's own start and goal). Time is the
whole request on a fresh planner: building the OMPL setup for the cage, planning, shortcutting and
resampling. "Samples" is the number of RRT iterations (samples drawn; each makes exactly one
motion check); tree vertices are printed too.

Part 2: ``--queries`` random valid start/goal pairs (uniform in the cage, clearance >= 1 m to the
known map, at least 5 m apart) over fresh cages (20 queries per cage), default options. Success
rate, time percentiles of warm requests (setup per cage reported apart), path length relative to a
visibility-graph lower bound of the shortest collision-free path, and the minimum clearance,
checked independently with ``cage_sim.world.segment_clearance`` on the full known map.

Part 3: where the time of one RRT request goes (instrumented motion validator).

Writes ``rrt_figure6.png`` (net, obstacles, tree, path per step size) to ``--out``; the last
printed line is one JSON object with the figures.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from cage_sim.scenarios import generate_cage
from cage_sim.world import segment_clearance
from cage_global_rrt import GlobalPlanner, PlannerOptions, PlanStatus
from cage_global_rrt.geometry import HAVE_NUMBA, point_valid, segment_valid
from cage_global_rrt.validity import SegmentMotionValidator

STUDY = {3: (4.60, 1323), 7: (1.87, 1047), 12: (1.47, 935)}
QUERIES_PER_CAGE = 20


def progress(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def warm_up() -> None:
    """Load the compiled kernels once so the first timed run does not pay for it."""
    sc = generate_cage(np.random.default_rng(12345))
    GlobalPlanner(sc.world, PlannerOptions(seed=1)).plan(sc.start, sc.goal)
    GlobalPlanner(sc.world, PlannerOptions(seed=1)).graph.shortest(sc.start, sc.goal)


# ----------------------------------------------------------------------------- part 1

def table3(runs: int, seed: int):
    rows, examples = {}, {}
    for step in STUDY:
        times, samples, vertices, fails = [], [], [], 0
        for run in range(runs):
            sc = generate_cage(np.random.default_rng(seed + run))
            opts = PlannerOptions(max_step=float(step), time_limit=5.0, seed=run + 1)
            t0 = time.perf_counter()
            planner = GlobalPlanner(sc.world, opts)
            r = planner.plan(sc.start, sc.goal, collect_tree=True)
            times.append(time.perf_counter() - t0)
            fails += not r.ok
            samples.append(r.samples)
            vertices.append(r.vertices)
            examples.setdefault(step, []).append((sc, r))
        rows[step] = dict(mean_time_s=float(np.mean(times)), median_time_s=float(np.median(times)),
                          mean_samples=float(np.mean(samples)), mean_vertices=float(np.mean(vertices)),
                          failures=fails)
        progress(f"table3: step {step} m done ({runs} runs)")
    # the figure shows the cage where the 3 m tree grew largest, at every step size
    i = int(np.argmax([r.samples for _, r in examples[3]]))
    return rows, {step: ex[i] for step, ex in examples.items()}


def print_table3(rows, runs):
    print(f"\nTable 3 side by side: RRT in the 30 m cage, 20 known 2x2 m squares, {runs} runs each")
    print(f"{'max step':>9} | {'study time':>10} {'ours mean':>10} {'ours med':>9} {'speed-up':>9} | "
          f"{'study samples':>13} {'ours samples':>12} {'ours vertices':>13} | fails")
    for step, row in rows.items():
        st, ss = STUDY[step]
        print(f"{step:>7} m | {st:>9.2f}s {row['mean_time_s'] * 1e3:>8.3f}ms {row['median_time_s'] * 1e3:>7.3f}ms "
              f"{st / row['mean_time_s']:>8.0f}x | {ss:>13d} {row['mean_samples']:>12.1f} "
              f"{row['mean_vertices']:>13.1f} | {row['failures']}")
    print("  ours: whole request on a fresh planner (OMPL setup + plan + shortcut + resample);"
          " samples = RRT iterations (samples drawn), vertices = tree size")


# ----------------------------------------------------------------------------- part 2

def random_query(rng, kmap, margin, min_dist=5.0):
    R = kmap.net_radius
    while True:
        pts = []
        while len(pts) < 2:
            r, a = R * math.sqrt(rng.random()), rng.uniform(-math.pi, math.pi)
            x, y = r * math.cos(a), r * math.sin(a)
            if point_valid(x, y, R, margin, kmap.squares, kmap.circles):
                pts.append((x, y))
        if math.dist(*pts) >= min_dist:
            return pts


def queries(n: int, seed: int):
    opts = PlannerOptions()
    rng = np.random.default_rng(seed + 10_000)
    times, ratios, clearances, setups, status = [], [], [], [], []
    cage_seed = seed + 100_000
    planner = None
    for i in range(n):
        if i % QUERIES_PER_CAGE == 0:
            sc = generate_cage(np.random.default_rng(cage_seed + i))
            known = sc.world.known_map()
            t0 = time.perf_counter()
            planner = GlobalPlanner(sc.world, opts)
            planner.env  # build the OMPL setup outside the timed requests
            setups.append(time.perf_counter() - t0)
        start, goal = random_query(rng, planner.kmap, opts.clearance)
        r = planner.plan(start, goal)
        status.append(int(r.status))
        times.append(r.planning_time)
        if r.ok:
            lb = planner.graph.shortest(start, goal)
            ratios.append(r.length / lb)
            clearances.append(segment_clearance(known, r.waypoints, resolution=0.05))
        if (i + 1) % 200 == 0:
            progress(f"queries: {i + 1}/{n}")
    t = np.asarray(times) * 1e3
    counts = {PlanStatus(c).name: status.count(c) for c in sorted(set(status))}
    return dict(n=n, success_rate=status.count(0) / n, status_counts=counts,
                time_ms_p50=float(np.percentile(t, 50)), time_ms_p90=float(np.percentile(t, 90)),
                time_ms_p99=float(np.percentile(t, 99)), time_ms_max=float(t.max()),
                setup_ms_median=float(np.median(setups) * 1e3),
                length_ratio_mean=float(np.mean(ratios)), length_ratio_p50=float(np.median(ratios)),
                length_ratio_p90=float(np.percentile(ratios, 90)), length_ratio_min=float(np.min(ratios)),
                min_clearance_m=float(np.min(clearances)), required_clearance_m=opts.clearance,
                clearance_check_resolution_m=0.05)


def print_queries(q):
    print(f"\n{q['n']} random valid queries (RRT, step 3 m, clearance {q['required_clearance_m']:g} m, "
          f"20 queries per fresh cage)")
    print(f"  success rate      {q['success_rate'] * 100:.1f} %   {q['status_counts']}")
    print(f"  time per request  p50 {q['time_ms_p50']:.3f} ms   p90 {q['time_ms_p90']:.3f} ms   "
          f"p99 {q['time_ms_p99']:.3f} ms   max {q['time_ms_max']:.3f} ms   "
          f"(setup per cage, apart: {q['setup_ms_median']:.3f} ms median)")
    print(f"  length / lower bound  mean {q['length_ratio_mean']:.3f}   p50 {q['length_ratio_p50']:.3f}   "
          f"p90 {q['length_ratio_p90']:.3f}   min {q['length_ratio_min']:.3f}")
    print(f"  minimum clearance {q['min_clearance_m']:.3f} m (required {q['required_clearance_m']:g} m; "
          f"segment_clearance at {q['clearance_check_resolution_m']} m on the known map)")


# ----------------------------------------------------------------------------- part 3

class TimedMotionValidator(SegmentMotionValidator):
    """The production validator with a clock around its body (adds ~0.1 us per call)."""

    def __init__(self, *a):
        super().__init__(*a)
        self.body = 0.0

    def checkMotion(self, a, b):  # noqa: N802
        t = time.perf_counter()
        ok = super().checkMotion(a, b)
        self.body += time.perf_counter() - t
        return ok


def profile(seed: int, n_cages: int = 20, repeats: int = 20):
    """Split one RRT request (step 3 m, warm planner) into its parts."""
    tot, solve, body, checks = [], [], [], []
    kernel_calls = []
    for k in range(n_cages):
        sc = generate_cage(np.random.default_rng(seed + k))
        gp = GlobalPlanner(sc.world, PlannerOptions(seed=k + 1))
        env = gp.env
        tm = TimedMotionValidator(env.si, gp.kmap, env.margin)
        env.si.setMotionValidator(tm)
        env.motion = tm
        for _ in range(repeats):
            tm.body, c0 = 0.0, tm.checks
            r = gp.plan(sc.start, sc.goal)
            tot.append(r.planning_time)
            solve.append(r.solve_time)
            body.append(tm.body)
            checks.append(tm.checks - c0)
        kernel_calls.append((sc, gp.kmap, env.margin))
    # the compiled kernel alone, called from Python on segments of the typical length
    sc, km, m = kernel_calls[0]
    rng = np.random.default_rng(seed)
    a = rng.uniform(-20, 20, (20000, 2))
    ang = rng.uniform(-math.pi, math.pi, 20000)
    b = a + 3.0 * np.column_stack((np.cos(ang), np.sin(ang)))
    segs = [tuple(map(float, (*p, *q))) for p, q in zip(a, b)]
    R, sq, ci = km.net_radius, km.squares, km.circles
    t0 = time.perf_counter()
    for ax, ay, bx, by in segs:
        segment_valid(ax, ay, bx, by, R, m, sq, ci)
    kernel_us = (time.perf_counter() - t0) / len(segs) * 1e6
    med = lambda v: float(np.median(v)) * 1e3  # noqa: E731
    calls = float(np.median(checks))
    p = dict(total_ms=med(tot), solve_ms=med(solve), callbacks_ms=med(body),
             ompl_and_crossing_ms=med(np.subtract(solve, body)), outside_solve_ms=med(np.subtract(tot, solve)),
             motion_checks=calls, kernel_us_per_call=kernel_us, numba=HAVE_NUMBA)
    return p


def print_profile(p):
    print("\nWhere the time of one RRT request goes (step 3 m, warm planner, medians):")
    print(f"  whole request                 {p['total_ms']:.3f} ms")
    print(f"  OMPL solve                    {p['solve_ms']:.3f} ms, of which")
    print(f"    Python checkMotion bodies   {p['callbacks_ms']:.3f} ms  ({p['motion_checks']:.0f} calls; the compiled "
          f"segment kernel alone is {p['kernel_us_per_call']:.2f} us/call from Python)")
    print(f"    OMPL C++ + nanobind crossing {p['ompl_and_crossing_ms']:.3f} ms")
    print(f"  outside solve (setup of the query, shortcut, resample, final check) {p['outside_solve_ms']:.3f} ms")


# ----------------------------------------------------------------------------- figure

def figure(examples, out: Path) -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle, FancyBboxPatch, Rectangle

    fig, axes = plt.subplots(1, len(examples), figsize=(6 * len(examples), 6))
    for ax, (step, (sc, r)) in zip(np.atleast_1d(axes), examples.items()):
        w = sc.world
        ax.add_patch(Circle((0, 0), w.net_radius, fill=False, color="k", lw=1.5))
        for ob in w.known:
            h = ob.size / 2
            ax.add_patch(Rectangle((ob.x - h, ob.y - h), ob.size, ob.size, color="0.3"))
            m = PlannerOptions().clearance
            ax.add_patch(FancyBboxPatch((ob.x - h, ob.y - h), ob.size, ob.size, boxstyle=f"round,pad={m}",
                                        fill=False, ls="--", lw=0.6, color="0.5"))
        for (x0, y0), (x1, y1) in r.tree or []:
            ax.plot([x0, x1], [y0, y1], color="tab:blue", lw=0.5, alpha=0.6)
        if r.ok:
            ax.plot(*r.raw_path.T, color="tab:orange", lw=1.2, label="RRT path")
            ax.plot(*r.waypoints.T, "o-", color="tab:red", ms=2, lw=1.5, label="shortcut + resampled")
        ax.plot(*sc.start[:2], "g^", ms=9, label="start")
        ax.plot(*sc.goal, "r*", ms=12, label="goal")
        ax.set_title(f"RRT, max step {step} m: {r.samples} samples, {r.vertices} vertices, "
                     f"{r.planning_time * 1e3:.2f} ms")
        ax.set_aspect("equal")
        ax.set_xlim(-w.net_radius - 1, w.net_radius + 1)
        ax.set_ylim(-w.net_radius - 1, w.net_radius + 1)
        ax.legend(loc="lower right", fontsize=7)
    fig.tight_layout()
    out.mkdir(parents=True, exist_ok=True)
    path = out / "rrt_figure6.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=20, help="cages per step size for Table 3 (study: 20)")
    ap.add_argument("--queries", type=int, default=1000, help="random valid queries")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("out"), help="folder for the figure")
    args = ap.parse_args(argv)
    if args.runs < 1 or args.queries < 1:
        ap.error("--runs and --queries must be >= 1")
    progress("warming up (loading compiled kernels)")
    warm_up()
    rows, examples = table3(args.runs, args.seed)
    print_table3(rows, args.runs)
    q = queries(args.queries, args.seed)
    print_queries(q)
    p = profile(args.seed)
    print_profile(p)
    png = figure(examples, args.out)
    print(f"\nfigure: {png}")
    summary = {"table3": {str(k): dict(v, study_time_s=STUDY[k][0], study_samples=STUDY[k][1],
                                       speedup=STUDY[k][0] / v["mean_time_s"]) for k, v in rows.items()},
               "queries": q, "profile": p, "runs": args.runs, "seed": args.seed}
    print(json.dumps(summary, separators=(",", ":")))
    return 0


if __name__ == "__main__":
    sys.exit(main())
