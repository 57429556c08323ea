"""Offline demo: one seeded episode of a scenario driven by a policy, printed and plotted.

``cage_demo`` runs the built-in full-cage scenario with the classical controller; the README's main
command runs the whole node graph instead (scripts/run_mission.sh) and uses this only as a fallback
check. Kept small: the evaluator (cage_reactive_ddpg) is the tool for many episodes.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .controller import ArcController
from .env import CageNavEnv
from .plotting import plot_episode
from .rollout import run_episode
from .scenarios import ScenarioError


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="full_cage", help="scenario name or YAML file")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--png", default="out/demo_track.png", help="where to write the track plot")
    args = ap.parse_args(argv)
    try:
        env = CageNavEnv(args.scenario)
    except ScenarioError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    ep = run_episode(env, ArcController(), seed=args.seed)
    sc = ep.scenario
    Path(args.png).parent.mkdir(parents=True, exist_ok=True)
    plot_episode(args.png, sc.world, ep.track, ep.outcome, sc.start, sc.goal, sc.route(),
                 title=f"{sc.name}, seed {args.seed}: {ep.outcome} in {ep.steps} steps")
    print(f"scenario={sc.name} seed={args.seed} controller=arc outcome={ep.outcome} steps={ep.steps} "
          f"travelled={ep.travelled:.1f}m route={ep.route_length:.1f}m min_clearance={ep.min_clearance:.2f}m")
    print(f"track plot: {args.png}")
    return 0 if ep.outcome == "goal" else 1


if __name__ == "__main__":
    sys.exit(main())
