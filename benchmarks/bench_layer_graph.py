"""The obstacle layer in the whole graph: the same seeded missions with rrt_node's ``obstacle_layer``
off and on (the reactive layer flying, replans requested by policy_node when it makes no progress).

The offline evaluator plans once per mission and never replans, so the layer cannot change its
outcomes; this runs the graph instead. Prints outcome counts side by side, the missions whose
outcome or decision count differ, and one JSON line. (Replans that re-enter a known return are
counted by ``bench_obstacle_layer.py``.)

    .venv/bin/python benchmarks/bench_layer_graph.py [--missions 40] [--scenario cage] [--planner rrt]
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_agreement import OUTCOMES, graph_mission  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--missions", type=int, default=40)
    ap.add_argument("--scenario", default="cage")
    ap.add_argument("--seed", type=int, default=100, help="first scenario seed")
    ap.add_argument("--planner", default="rrt", help="rrt_node planner (rrt, optimal, ...)")
    ap.add_argument("--policy", default="", help="policy file or baseline (default: the shipped policy)")
    ap.add_argument("--time-scale", type=float, default=50.0)
    a = ap.parse_args()
    runs: dict[str, list[dict]] = {"off": [], "on": []}
    t0 = time.time()
    for k in range(a.missions):
        seed = a.seed + k
        for layer in ("off", "on"):
            extra = ("--rrt-param", f"planner:={a.planner}", "--rrt-param",
                     f"obstacle_layer:={'true' if layer == 'on' else 'false'}")
            runs[layer].append(graph_mission(a.scenario, seed, a.policy, a.time_scale, extra=extra))
        off, on = runs["off"][-1], runs["on"][-1]
        print(f"[{k + 1}/{a.missions}] seed {seed}: layer off {off['outcome']} ({off['steps']}), "
              f"on {on['outcome']} ({on['steps']})  {time.time() - t0:.0f} s", flush=True)
    counts = {layer: Counter(r["outcome"] for r in rs) for layer, rs in runs.items()}
    print(f"\n{'outcome':<10}{'layer off':>10}{'layer on':>10}")
    for o in (*OUTCOMES, "error"):
        print(f"{o:<10}{counts['off'][o]:>10}{counts['on'][o]:>10}")
    differ = [a.seed + i for i, (x, y) in enumerate(zip(runs["off"], runs["on"]))
              if (x["outcome"], x["steps"]) != (y["outcome"], y["steps"])]
    print(f"missions that differ (outcome or decisions): {len(differ)} {differ}")
    print(json.dumps({"bench_layer_graph": {"missions": a.missions, "scenario": a.scenario, "planner": a.planner,
                                            "off": dict(counts["off"]), "on": dict(counts["on"]),
                                            "differ": differ}}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
