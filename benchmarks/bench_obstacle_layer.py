#!/usr/bin/env python3
"""Offline evaluation of the obstacle layer: do replans re-enter returns the sonar already confirmed?

Each full cage (``generate_cage``: 20 known squares, unknown static and moving obstacles, fish
schools) is flown twice by a route follower with no reactive layer: the vehicle moves along the
planned route ``--step`` m per sonar scan (study sonar, 360 deg, 20 m) and, when its next position
would come closer than ``--stop`` m to anything real (unknown obstacles included), it stops and
asks the global planner for a new route from where it is: once on the known map only (today),
once on the known map plus the obstacle layer (``ObstacleLayer.planning_map``). A replan
"re-enters a known return" when its route passes closer than the clearance to a return seen in at
least ``confirm_scans`` scans, and closer than the vehicle already is (leaving the spot where it
stopped, next to the obstacle, is not a re-entry). Without the layer the follower cannot get past the obstacle (its
replan is the same route); with it, it flies on. Counts, goals reached and per-replan times are
printed as a table; the last line is one JSON object.

This isolates the global layer: the full-cage evaluation with the reactive policy is the
evaluator's (``evaluate``); see docs/notes/planner.md.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time

import numpy as np

from cage_sim.scenarios import generate_cage
from cage_sim.sonar import make_sonar
from cage_global_rrt import GlobalPlanner, PlannerOptions
from cage_global_rrt.known_map import KnownMap
from cage_global_rrt.obstacle_layer import LayerParams, ObstacleLayer, plan_with_layer


def confirmed_returns(layer: ObstacleLayer) -> np.ndarray:
    n = layer.params.confirm_scans
    pts = [(c.sx / c.n, c.sy / c.n) for c in layer.cells.values() if c.hits >= n]
    return np.asarray(pts).reshape(-1, 2)


def min_dist_to_points(path: np.ndarray, pts: np.ndarray) -> float:
    """Least distance from the polyline to any of the points (exact per segment)."""
    if len(pts) == 0 or len(path) < 2:
        return math.inf
    a, b = path[:-1, None, :], path[1:, None, :]
    ab = b - a
    t = np.clip(((pts[None] - a) * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-12), 0.0, 1.0)
    d = np.hypot(*(a + t[..., None] * ab - pts[None]).transpose(2, 0, 1))
    return float(d.min())


def fly(sc, use_layer: bool, opts: PlannerOptions, step: float, stop: float, max_replans: int, sonar):
    """Follow routes until the goal, or until stuck (a replan that fails or max_replans)."""
    known = KnownMap.from_world(sc.world)
    layer = ObstacleLayer(known, LayerParams())
    planner = GlobalPlanner(known, opts)
    goal = tuple(sc.goal[:2])
    pos = np.asarray(sc.start[:2], dtype=float)
    res = planner.plan(pos, goal)
    if not res.ok:
        return dict(reached=False, replans=0, reentries=0, failed=1, fallbacks=0, reentries_layered=0, times=[],
                    travelled=0.0)
    route, i, t, travelled = res.waypoints, 1, 0.0, 0.0
    replans = reentries = failed = fallbacks = reentries_layered = 0
    times = []
    yaw = math.atan2(*(route[1] - route[0])[::-1])
    while True:
        layer.update((pos[0], pos[1], yaw), sonar.scan(sc.world, pos[0], pos[1], yaw, t), sonar.angles,
                     sonar.max_range)
        if math.dist(pos, goal) < 1e-6:
            return dict(reached=True, replans=replans, reentries=reentries, failed=failed, fallbacks=fallbacks,
                        reentries_layered=reentries_layered, times=times, travelled=travelled)
        target = route[i]
        d = math.dist(pos, target)
        nxt = target if d <= step else pos + (target - pos) * (step / d)
        if sc.world.clearance(nxt[0], nxt[1], t + step) < stop:
            if replans >= max_replans:
                return dict(reached=False, replans=replans, reentries=reentries, failed=failed, fallbacks=fallbacks,
                        reentries_layered=reentries_layered, times=times, travelled=travelled)
            replans += 1
            t0 = time.perf_counter()
            if not use_layer:
                planner.set_map(known)
            res = plan_with_layer(planner, layer if use_layer else None, pos, goal)
            times.append(time.perf_counter() - t0)
            if not res.ok:
                failed += 1
                return dict(reached=False, replans=replans, reentries=reentries, failed=failed, fallbacks=fallbacks,
                        reentries_layered=reentries_layered, times=times, travelled=travelled)
            seen = confirmed_returns(layer)
            d_now = min_dist_to_points(np.vstack((pos, pos)), seen)
            fell_back = "known map only" in res.message
            fallbacks += fell_back
            if min_dist_to_points(res.waypoints, seen) < min(opts.clearance, d_now) - 0.05:
                reentries += 1
                reentries_layered += not fell_back
            route, i = res.waypoints, 1
            t += 1.0   # the scan spent deciding
            continue
        yaw = math.atan2(nxt[1] - pos[1], nxt[0] - pos[0]) if math.dist(nxt, pos) > 1e-9 else yaw
        travelled += math.dist(pos, nxt)
        pos = np.asarray(nxt, dtype=float)
        t += step
        if d <= step:
            i = min(i + 1, len(route) - 1)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cages", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--planner", default="optimal", help="planner for the routes (rrt, optimal, ...)")
    ap.add_argument("--step", type=float, default=1.0, help="m flown per sonar scan")
    ap.add_argument("--stop", type=float, default=0.75, help="m: stop and replan when closer than this")
    ap.add_argument("--max-replans", type=int, default=10)
    args = ap.parse_args(argv)
    opts = PlannerOptions(planner=args.planner, seed=1, waypoint_spacing=0.0)
    if opts.error():
        ap.error(opts.error())
    sonar = make_sonar("study")
    rows = {}
    for use_layer in (False, True):
        agg = dict(cages=0, reached=0, replans=0, reentries=0, failed=0, times=[], stuck=0, fallbacks=0,
                   reentries_layered=0)
        for c in range(args.cages):
            sc = generate_cage(np.random.default_rng(args.seed + c))
            r = fly(sc, use_layer, opts, args.step, args.stop, args.max_replans, sonar)
            agg["cages"] += 1
            agg["reached"] += r["reached"]
            agg["stuck"] += not r["reached"]
            for k in ("replans", "reentries", "failed", "fallbacks", "reentries_layered"):
                agg[k] += r[k]
            agg["times"] += r["times"]
        t = np.asarray(agg.pop("times") or [0.0]) * 1e3
        agg.update(replan_ms_p50=float(np.percentile(t, 50)), replan_ms_p99=float(np.percentile(t, 99)))
        rows["layer" if use_layer else "known map only"] = agg
        print(f"{'layer' if use_layer else 'no layer'}: done", file=sys.stderr, flush=True)
    print(f"\nRoute follower without reactive layer, {args.cages} full cages, planner {args.planner}, "
          f"step {args.step} m per scan, stop at {args.stop} m")
    print(f"{'map':>15} | {'goal reached':>12} {'stuck':>6} | {'replans':>7} {'re-enter known return':>22} "
          f"{'failed':>6} {'fell back':>9} {'re-enter (layer plans)':>22} | {'replan p50':>10} {'p99':>8}")
    for name, a in rows.items():
        print(f"{name:>15} | {a['reached']:>12d} {a['stuck']:>6d} | {a['replans']:>7d} {a['reentries']:>22d} "
              f"{a['failed']:>6d} {a['fallbacks']:>9d} {a['reentries_layered']:>22d} | "
              f"{a['replan_ms_p50']:>8.3f}ms {a['replan_ms_p99']:>6.3f}ms")
    print("  fell back: the learnt obstacles closed every way, so the replan was made on the known map only "
          "(plan_with_layer); re-enter (layer plans): re-entries among the replans that used the layer")
    print(json.dumps(dict(rows=rows, cages=args.cages, seed=args.seed, planner=args.planner, step=args.step,
                          stop=args.stop), separators=(",", ":")))
    return 0


if __name__ == "__main__":
    sys.exit(main())
