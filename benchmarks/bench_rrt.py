#!/usr/bin/env python3
"""Benchmark of the global planner against the source study's Table 3, plus 1000 random queries.

Part 1 (Table 3): the 30 m cage with 20 random 2 x 2 m known squares (``generate_cage``), RRT at
max step 3, 7 and 12 m, ``--runs`` cages each (the scenario's own start and goal). Time is the
whole request on a fresh planner: building the OMPL setup for the cage, planning, shortcutting and
resampling. "Samples" is the number of RRT iterations (samples drawn; each makes exactly one
motion check); tree vertices are printed too.

Table 3 also gets the ``optimal`` planner's row (visibility graph built for the cage + one query;
the warm query time is printed under it).

Part 2: ``--queries`` random valid start/goal pairs (uniform in the cage, clearance >= 1 m to the
known map, at least 5 m apart) over fresh cages (20 queries per cage), the same pairs for every
planner: rrt, rrtconnect, optimal, optimal + flyable, rrt + flyable, and on the first
``--slow-queries`` pairs RRT*, Informed RRT* (``--star-time`` s) and today's Dubins mode. Success
rate, time percentiles of warm requests (setup per cage reported apart), path length relative to
the optimum under the clearance (the ``optimal`` planner's length; its own ratio to the
inscribed-polygon lower bound is printed too), the minimum clearance, checked independently with
``cage_sim.world.segment_clearance`` on the full known map, and for the curved modes the least turn
radius of three consecutive waypoints and the clearance sampled along the true arcs.

Part 3: where the time of one RRT request goes (instrumented motion validator).

Writes ``rrt_figure6.png`` (net, obstacles, tree, path per step size) and ``rrt_optimal_flyable.png``
(RRT, optimal and flyable paths on one cage) to ``--out``; the last printed line is one JSON object
with the figures.
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
from cage_global_rrt import GlobalPlanner, KnownMap, PlannerOptions, PlanStatus
from cage_global_rrt.geometry import HAVE_NUMBA, point_valid, segment_valid
from cage_global_rrt.visibility import optimal_graph
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
    GlobalPlanner(sc.world, PlannerOptions(planner="optimal", flyable=True)).plan(sc.start, sc.goal)


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


def table3_optimal(runs: int, seed: int):
    """The optimal planner on Table 3's cages: a fresh request (graph built for the cage, then one
    query) and a warm one (graph already built: what every later query on the cage costs)."""
    from cage_global_rrt import visibility
    fresh, warm, verts, edges, fails = [], [], [], [], 0
    for run in range(runs):
        sc = generate_cage(np.random.default_rng(seed + run))
        visibility._GRAPHS.clear()   # a really fresh graph
        t0 = time.perf_counter()
        planner = GlobalPlanner(sc.world, PlannerOptions(planner="optimal"))
        r = planner.plan(sc.start, sc.goal)
        fresh.append(time.perf_counter() - t0)
        warm.append(min(planner.plan(sc.start, sc.goal).planning_time for _ in range(5)))
        fails += not r.ok
        g = planner.optimal
        verts.append(int(g.valid.sum()))
        edges.append(g.edges)
    return dict(mean_time_s=float(np.mean(fresh)), median_time_s=float(np.median(fresh)),
                warm_mean_time_s=float(np.mean(warm)), warm_median_time_s=float(np.median(warm)),
                mean_graph_vertices=float(np.mean(verts)), mean_graph_edges=float(np.mean(edges)), failures=fails)


def print_table3(rows, runs):
    print(f"\nTable 3 side by side: RRT in the 30 m cage, 20 known 2x2 m squares, {runs} runs each")
    print(f"{'max step':>9} | {'study time':>10} {'ours mean':>10} {'ours med':>9} {'speed-up':>9} | "
          f"{'study samples':>13} {'ours samples':>12} {'ours vertices':>13} | fails")
    for step, row in rows.items():
        if step not in STUDY:
            continue
        st, ss = STUDY[step]
        print(f"{step:>7} m | {st:>9.2f}s {row['mean_time_s'] * 1e3:>8.3f}ms {row['median_time_s'] * 1e3:>7.3f}ms "
              f"{st / row['mean_time_s']:>8.0f}x | {ss:>13d} {row['mean_samples']:>12.1f} "
              f"{row['mean_vertices']:>13.1f} | {row['failures']}")
    print("  ours: whole request on a fresh planner (OMPL setup + plan + shortcut + resample);"
          " samples = RRT iterations (samples drawn), vertices = tree size")
    o = rows.get("optimal")
    if o:
        st = STUDY[3][0]
        print(f"{'optimal':>9} | {'':>10} {o['mean_time_s'] * 1e3:>8.3f}ms {o['median_time_s'] * 1e3:>7.3f}ms "
              f"{st / o['mean_time_s']:>8.0f}x | {'':>13} {'-':>12} {o['mean_graph_vertices']:>13.1f} | {o['failures']}")
        print(f"  optimal: fresh request = visibility graph for the cage ({o['mean_graph_edges']:.0f} edges) + one query;"
              f" a warm query (graph built) takes {o['warm_median_time_s'] * 1e3:.3f} ms median;"
              " speed-up against the study's 3 m row; vertices = graph vertices")


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


def query_set(n: int, seed: int, clearance: float):
    """[(scenario, [(start, goal), ...]), ...]: 20 queries per fresh cage, the same for every planner."""
    rng = np.random.default_rng(seed + 10_000)
    out = []
    for i in range(0, n, QUERIES_PER_CAGE):
        sc = generate_cage(np.random.default_rng(seed + 100_000 + i))
        km = KnownMap.from_world(sc.world)
        out.append((sc, [random_query(rng, km, clearance) for _ in range(min(QUERIES_PER_CAGE, n - i))]))
    return out


def arc_clearance(known, r, step: float = 0.01) -> float:
    """Least clearance along the true arcs of a flyable result (sampled every ``step`` m)."""
    best = math.inf
    for cx, cy, rad in r.arcs or []:
        c = np.array([cx, cy])
        on = np.abs(np.hypot(*(r.waypoints - c).T) - rad) < 1e-6
        for i in np.flatnonzero(on[:-1] & on[1:]):
            a0 = math.atan2(*(r.waypoints[i] - c)[::-1])
            da = math.remainder(math.atan2(*(r.waypoints[i + 1] - c)[::-1]) - a0, 2 * math.pi)
            for a in a0 + da * np.linspace(0, 1, max(2, int(abs(da) * rad / step))):
                best = min(best, known.clearance(cx + rad * math.cos(a), cy + rad * math.sin(a)))
    return best


def min_turn_radius(p: np.ndarray) -> float:
    """Smallest circumradius of three consecutive waypoints (inf on straight runs)."""
    if len(p) < 3:
        return math.inf
    a, b, c = p[:-2], p[1:-1], p[2:]
    ab, bc, ca = np.hypot(*(b - a).T), np.hypot(*(c - b).T), np.hypot(*(a - c).T)
    cross = np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
    with np.errstate(divide="ignore"):
        return float(np.where(cross > 1e-9, ab * bc * ca / (2.0 * cross), np.inf).min())


def queries(qset, opts: PlannerOptions, label: str, repeat: int = 1):
    """Every query of ``qset`` with ``opts`` on one planner per cage (its setup timed apart). The
    deterministic optimal planner's requests are repeated ``repeat`` times and the least time kept
    (its result is the same each time; on a shared machine the least time is its own cost)."""
    times, ratios, lb_ratios, clearances, setups, status = [], [], [], [], [], []
    radii, arc_clear, flyable = [], [], []
    n = 0
    for sc, qs in qset:
        known = sc.world.known_map()
        t0 = time.perf_counter()
        planner = GlobalPlanner(sc.world, opts)
        planner.prepare()  # the OMPL setup or the visibility graph, outside the timed requests
        setups.append(time.perf_counter() - t0)
        best = optimal_graph(planner.kmap, opts.clearance)
        for start, goal in qs:
            n += 1
            r = planner.plan(start, goal)
            t_req = r.planning_time
            for _ in range(repeat - 1 if opts.planner == "optimal" else 0):
                t_req = min(t_req, planner.plan(start, goal).planning_time)
            status.append(int(r.status))
            times.append(t_req)
            if r.ok:
                ratios.append(r.length / best.shortest(start, goal))
                lb_ratios.append(r.length / planner.graph.shortest(start, goal))
                clearances.append(segment_clearance(known, r.waypoints, resolution=0.05))
                if opts.flyable or opts.dubins:
                    flyable.append(bool(r.flyable) if opts.flyable else True)
                    radii.append(min_turn_radius(r.waypoints))
                    if opts.flyable:
                        arc_clear.append(arc_clearance(known, r))
        progress(f"queries {label}: {n} done")
    t = np.asarray(times) * 1e3
    counts = {PlanStatus(c).name: status.count(c) for c in sorted(set(status))}
    out = dict(label=label, n=n, success_rate=status.count(0) / n, status_counts=counts,
               time_ms_p50=float(np.percentile(t, 50)), time_ms_p90=float(np.percentile(t, 90)),
               time_ms_p99=float(np.percentile(t, 99)), time_ms_max=float(t.max()),
               setup_ms_median=float(np.median(setups) * 1e3),
               length_ratio_mean=float(np.mean(ratios)), length_ratio_p50=float(np.median(ratios)),
               length_ratio_p90=float(np.percentile(ratios, 90)), length_ratio_max=float(np.max(ratios)),
               length_ratio_min=float(np.min(ratios)), lower_bound_ratio_mean=float(np.mean(lb_ratios)),
               min_clearance_m=float(np.min(clearances)), required_clearance_m=opts.clearance,
               clearance_check_resolution_m=0.05, time_limit_s=opts.time_limit,
               timed_as=f"least of {repeat}" if opts.planner == "optimal" and repeat > 1 else "single")
    if radii:
        out.update(flyable_rate=float(np.mean(flyable)), min_turn_radius_m=float(np.min(radii)),
                   turning_radius_m=opts.turning_radius)
        # the radius over flyable results only (a corner path kept where arcs did not fit has no arcs)
        fr = [rad for rad, f in zip(radii, flyable) if f]
        out["min_turn_radius_flyable_m"] = float(np.min(fr)) if fr else math.inf
    if arc_clear:
        out["min_arc_clearance_m"] = float(np.min(arc_clear))
    return out


def print_queries(rows):
    q0 = rows[0]
    print(f"\nRandom valid queries ({QUERIES_PER_CAGE} per fresh cage, clearance {q0['required_clearance_m']:g} m; "
          "time = warm request, the planner's setup per cage apart; length / optimum = length over the "
          "'optimal' planner's on the same query)")
    print("  (optimal rows: least of --repeat timings per request, see 'timed_as' in the JSON; others: one)")
    print(f"{'planner':>22} {'n':>5} {'success':>8} | {'p50 ms':>8} {'p90 ms':>8} {'p99 ms':>8} {'max ms':>8} "
          f"{'setup ms':>8} | {'len/opt mean':>12} {'p90':>6} {'max':>6} | {'min clear':>9}")
    for q in rows:
        print(f"{q['label']:>22} {q['n']:>5} {q['success_rate'] * 100:>7.1f}% | {q['time_ms_p50']:>8.3f} "
              f"{q['time_ms_p90']:>8.3f} {q['time_ms_p99']:>8.3f} {q['time_ms_max']:>8.3f} {q['setup_ms_median']:>8.3f} | "
              f"{q['length_ratio_mean']:>12.4f} {q['length_ratio_p90']:>6.3f} {q['length_ratio_max']:>6.3f} | "
              f"{q['min_clearance_m']:>8.3f}m")
    for q in rows:
        if "flyable_rate" in q:
            extra = f", least clearance along the true arcs {q['min_arc_clearance_m']:.3f} m" \
                if "min_arc_clearance_m" in q else ""
            print(f"  {q['label']}: turns of radius >= {q['turning_radius_m']:g} m on {q['flyable_rate'] * 100:.1f} % "
                  f"of paths; least turn radius {q['min_turn_radius_flyable_m']:.3f} m on those{extra}")
    opt = next((q for q in rows if q["label"] == "optimal"), None)
    if opt:
        print(f"  optimal vs the inscribed-polygon lower bound: mean {opt['lower_bound_ratio_mean']:.4f} "
              "(the true optimum lies between the two)")


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
        _frame(ax, w)
    return _save(fig, out / "rrt_figure6.png")


def _frame(ax, w) -> None:
    """The whole cage, to scale, with the legend in a corner."""
    ax.set_aspect("equal")
    ax.set_xlim(-w.net_radius - 1, w.net_radius + 1)
    ax.set_ylim(-w.net_radius - 1, w.net_radius + 1)
    ax.legend(loc="lower right", fontsize=7)


def _save(fig, path: Path) -> Path:
    import matplotlib.pyplot as plt
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def figure_optimal(cage_queries, out: Path) -> Path:
    """RRT, optimal and flyable paths on one cage (with the inflated obstacles), for the query of
    the cage's set whose shortest path bends most (a straight line shows nothing)."""
    sc, qs = cage_queries
    g = optimal_graph(KnownMap.from_world(sc.world), PlannerOptions().clearance)
    start, goal = max(qs, key=lambda q: g.shortest(*q) / math.dist(*q))
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle, FancyBboxPatch, Rectangle

    base = PlannerOptions(seed=1, waypoint_spacing=0.0)
    runs = [("RRT (shortcut)", base, "tab:orange", "-"), ("optimal", base.with_(planner="optimal"), "tab:blue", "-"),
            ("optimal + flyable", base.with_(planner="optimal", flyable=True), "tab:red", "-")]
    fig, ax = plt.subplots(figsize=(7, 7))
    w = sc.world
    m = base.clearance
    ax.add_patch(Circle((0, 0), w.net_radius, fill=False, color="k", lw=1.5))
    ax.add_patch(Circle((0, 0), w.net_radius - m, fill=False, color="0.5", lw=0.6, ls="--"))
    for ob in w.known:
        h = ob.size / 2
        ax.add_patch(Rectangle((ob.x - h, ob.y - h), ob.size, ob.size, color="0.3"))
        ax.add_patch(FancyBboxPatch((ob.x - h, ob.y - h), ob.size, ob.size, boxstyle=f"round,pad={m}",
                                    fill=False, ls="--", lw=0.6, color="0.5"))
    for label, opts, color, ls in runs:
        planner = GlobalPlanner(sc.world, opts)
        planner.prepare()
        r = planner.plan(start, goal)
        if r.ok:
            ax.plot(*r.waypoints.T, ls, color=color, lw=1.6, marker="o" if "flyable" in label else None, ms=2,
                    label=f"{label}: {r.length:.2f} m, {r.planning_time * 1e3:.2f} ms")
            for cx, cy, rad in r.arcs or []:
                ax.add_patch(Circle((cx, cy), rad, fill=False, color=color, lw=0.4, ls=":"))
    ax.plot(*start, "g^", ms=9, label="start")
    ax.plot(*goal, "r*", ms=12, label="goal")
    ax.set_title(f"Optimal and flyable paths (clearance {m:g} m, turn radius {base.turning_radius:.2f} m)")
    _frame(ax, w)
    return _save(fig, out / "rrt_optimal_flyable.png")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=20, help="cages per step size for Table 3 (study: 20)")
    ap.add_argument("--queries", type=int, default=1000, help="random valid queries")
    ap.add_argument("--slow-queries", type=int, default=100,
                    help="queries for the slow rows (RRT*, Informed RRT*, Dubins), a prefix of the same set")
    ap.add_argument("--repeat", type=int, default=3,
                    help="optimal rows: time each request this many times and keep the least")
    ap.add_argument("--star-time", type=float, default=0.05, help="time limit (s) of RRT* / Informed RRT*")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("out"), help="folder for the figure")
    args = ap.parse_args(argv)
    if args.runs < 1 or args.queries < 1:
        ap.error("--runs and --queries must be >= 1")
    progress("warming up (loading compiled kernels)")
    warm_up()
    rows, examples = table3(args.runs, args.seed)
    rows["optimal"] = table3_optimal(args.runs, args.seed)
    print_table3(rows, args.runs)
    base = PlannerOptions()
    qset = query_set(args.queries, args.seed, base.clearance)
    small = query_set(min(args.queries, args.slow_queries), args.seed, base.clearance)
    qrows = [queries(qset, base, "rrt"), queries(qset, base.with_(planner="rrtconnect"), "rrtconnect"),
             queries(qset, base.with_(planner="optimal"), "optimal", args.repeat),
             queries(qset, base.with_(planner="optimal", flyable=True), "optimal + flyable", args.repeat),
             queries(qset, base.with_(flyable=True), "rrt + flyable"),
             queries(small, base.with_(planner="rrtstar", time_limit=args.star_time), "rrtstar"),
             queries(small, base.with_(planner="informedrrtstar", time_limit=args.star_time), "informedrrtstar"),
             queries(small, base.with_(dubins=True), "rrt dubins (today)")]
    print_queries(qrows)
    p = profile(args.seed)
    print_profile(p)
    png = figure(examples, args.out)
    print(f"\nfigure: {png}")
    print(f"figure: {figure_optimal(qset[0], args.out)}")
    table = {}
    for k, v in rows.items():
        st, ss = STUDY[3 if k == "optimal" else k]
        table[str(k)] = dict(v, study_time_s=st, study_samples=ss, speedup=st / v["mean_time_s"])
    summary = {"table3": table, "queries": qrows[0], "planners": qrows, "profile": p, "runs": args.runs,
               "seed": args.seed}
    print(json.dumps(summary, separators=(",", ":")))
    return 0


if __name__ == "__main__":
    sys.exit(main())
