"""Decision time of the shipped driver (policy + shield) offline, one vehicle at a time as in policy_node.

Flies N held-out missions of one sea-matrix cell (default: cell 23, 0.5 m/s, small obstacles, goal by
the net, schools: where the shield works hardest) and times every decision from the scan to the
action (observation, policy forward, shield). Prints p50 / p99 / max for all decisions, for those of
the final approach (goal within the shield's ``sure_within``), for those where the goal search
ran and for the search itself (``through_goal``), and the same for a reference shield side by side
(default: ``goal_search`` off; ``--ref known_map=0``: the same shield without the known map), with
ratios.
Both fly the same missions one after the other; the outcomes are printed too (they may differ: the
shields decide differently). Never run as a test.

    .venv/bin/python benchmarks/bench_decide.py [--cell 23] [--missions 40] [--seed 2026] [--ref goal_search=0]
        [--sensor fls] [--remembered all]

``--sensor``: that profile's shipped driver (default: the default driver); ``--remembered``: the
remembered returns the shipped shield counts; ``--ref remembered=cleared``: a reference that
differs in that setting only (what clearing the memory costs a decision).
"""
from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np


def fly(shield, env, scenarios, routes, known_map: bool = True) -> dict:
    """Every decision's time (s) and kind, and the outcomes, for ``scenarios`` flown one by one."""
    from cage_reactive_ddpg.evaluate import replan_if_asked
    from cage_sim.driver import Driver, decide_batch, mission_moment
    from cage_sim.mission import Mission, noise_stream, observe_batch
    from cage_sim.route import ReplanWatch
    searched = []                                      # each search's own time (s)
    inner = shield.through_goal

    def counted(*args, **kw):
        t = time.perf_counter()
        found = inner(*args, **kw)
        searched.append(time.perf_counter() - t)
        return found
    shield.through_goal = counted
    times, kinds, outcomes = [], [], {}
    for sc in scenarios:
        m, noise = Mission(sc, env), noise_stream(sc)
        d = Driver(shield, env.layout, env.vehicle, m.builder, True, m.map_points if known_map else None, env.sonar)
        watch = ReplanWatch.defaults()
        while True:
            mo = mission_moment(m)
            final = mo.final and m.tracker.waypoint(*m.pose)[0] < shield.sure_within
            n = len(searched)
            t0 = time.perf_counter()
            obs = observe_batch(env, [m], [noise])
            act, _ = decide_batch([d], obs, [mo])
            times.append(time.perf_counter() - t0)
            kinds.append("search" if len(searched) > n else "final" if final else "other")
            _, outcome = m.step(float(np.clip(act[0], -1.0, 1.0)))
            if outcome is not None:
                outcomes[outcome] = outcomes.get(outcome, 0) + 1
                break
            replan_if_asked(m, watch, routes)
    shield.through_goal = inner
    return {"times": np.array(times), "kinds": np.array(kinds), "outcomes": outcomes, "searches": np.array(searched)}


def stats(ms: np.ndarray) -> dict:
    if not len(ms):
        return {"n": 0, "p50": math.nan, "p99": math.nan, "max": math.nan}
    return {"n": int(len(ms)), "p50": float(np.percentile(ms, 50)), "p99": float(np.percentile(ms, 99)),
            "max": float(ms.max())}


def groups(run: dict) -> dict:
    ms, kinds = run["times"] * 1000.0, run["kinds"]
    return {"all": stats(ms), "final approach": stats(ms[kinds != "other"]),
            "goal search": stats(ms[kinds == "search"]), "the search itself": stats(run["searches"] * 1000.0),
            "outcomes": run["outcomes"]}


def main(argv: list[str] | None = None) -> int:
    from cage_sim.controller import REMEMBERED
    from cage_sim.driver import DEFAULT_REMEMBERED
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cell", type=int, default=23)
    ap.add_argument("--missions", type=int, default=40)
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--ref", default="goal_search=0",
                    help="the reference shield: FIELD=0/1 of SafetyShield, known_map=0 (no known map), or "
                         "remembered=VALUE (the fallback's remembered returns)")
    ap.add_argument("--sensor", default=None, help="fly that profile's shipped driver (default: the default driver)")
    ap.add_argument("--remembered", default=DEFAULT_REMEMBERED, choices=list(REMEMBERED),
                    help="the shipped shield's remembered returns (default: the flown drivers')")
    a = ap.parse_args(argv)
    from dataclasses import replace

    from cage_reactive_ddpg.evaluate import driver_env, load_driver
    from cage_reactive_ddpg.matrix import MATRICES
    from cage_reactive_ddpg.missions import waypoint_fn
    field, value = a.ref.split("=")
    shield, _, meta = load_driver(None, sensor=a.sensor, remembered=a.remembered)
    ref_map = field != "known_map" or bool(int(value))
    if field == "remembered":
        reference = replace(shield, fallback=replace(shield.fallback, remembered=value))
    else:
        reference = shield if field == "known_map" else replace(shield, **{field: bool(int(value))})
    env = driver_env(meta, argparse.Namespace(motion=None, sensor=None))
    routes, cell = waypoint_fn("rrt"), MATRICES["sea"][a.cell]
    scs = []
    for i in range(a.missions):
        sc = cell.sample(np.random.default_rng([a.seed, a.cell, i]))
        scs.append(sc.with_waypoints(routes(sc)))
    fly(shield, env, scs[:2], routes)                  # warm-up: numba kernels, caches
    runs = {"shipped": groups(fly(shield, env, scs, routes)), a.ref: groups(fly(reference, env, scs, routes, ref_map))}
    print(f"cell {a.cell} ({cell.name}), {a.missions} missions of seed {a.seed}, one vehicle, ms per decision")
    print(f"{'decisions':16s} {'driver':22s} {'n':>6s} {'p50':>7s} {'p99':>7s} {'max':>7s}")
    for g in ("all", "final approach", "goal search", "the search itself"):
        for name, r in runs.items():
            s = r[g]
            print(f"{g:16s} {name:22s} {s['n']:6d} {s['p50']:7.2f} {s['p99']:7.2f} {s['max']:7.2f}")
        s, ref = runs["shipped"][g], runs[a.ref][g]
        if s["n"] and ref["n"]:
            print(f"{'':16s} {'ratio shipped / ref':22s} {'':6s} {s['p50'] / ref['p50']:7.2f} "
                  f"{s['p99'] / ref['p99']:7.2f}")
    for name, r in runs.items():
        print(f"outcomes, {name}: {r['outcomes']}")
    print(json.dumps({"cell": a.cell, "missions": a.missions, "seed": a.seed, "runs": runs}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
