"""Where training and evaluation missions come from: scenario specs, mixes, routes, seeded episode lists.

A spec is a cage_sim scenario name or YAML file, or a weighted mix ``"study2d:0.5,cage:0.5"`` (each
episode draws its scenario kind, then the scenario). Routes come from the global planner
(``planner="rrt"``, when ``cage_global_rrt`` is installed) or are straight segments to the goal.
Episode ``i`` of an evaluation with seed ``s`` is always drawn from ``default_rng([s, i])``: the same
seed gives the same episodes for every policy and the baseline, however they are batched.
"""
from __future__ import annotations

from typing import Callable, Sequence

import numpy as np
from cage_sim.scenarios import Sampler, Scenario, scenario_sampler

WaypointFn = Callable[[Scenario], Sequence[Sequence[float]] | None]


def parse_mix(spec: str) -> list[tuple[str, float]]:
    """``"a:0.7,b:0.3"`` -> [(a, .7), (b, .3)]; a plain name or file -> [(spec, 1)].

    A sea cell ``sea:current=0.25,obstacles=small`` is one name (its commas are not a mix)."""
    if spec.startswith("sea:"):
        return [(spec, 1.0)]
    parts = [p.strip() for p in spec.split(",") if p.strip()]
    if len(parts) == 1 and ":" not in parts[0]:
        return [(parts[0], 1.0)]
    out = []
    for p in parts:
        name, _, w = p.rpartition(":")
        if not name:
            name, w = w, "1"
        out.append((name, float(w)))
    return out


def sampler(spec: str) -> Sampler:
    """A scenario sampler for a spec (name, file or weighted mix)."""
    from .matrix import family_sampler
    mix = parse_mix(spec)
    samplers = [family_sampler(name) or scenario_sampler(name) for name, _ in mix]
    if len(samplers) == 1:
        return samplers[0]
    w = np.array([wt for _, wt in mix], dtype=float)
    w /= w.sum()

    def draw(rng: np.random.Generator) -> Scenario:
        return samplers[int(rng.choice(len(samplers), p=w))](rng)
    return draw


RRT_NET_MODELS = {"rrt": "nominal", "rrt_current": "current"}   # planner name -> the net wall it plans on
PLANNERS = ("none", *RRT_NET_MODELS, "dense", "dense_mix")


def dense_route(sc: Scenario, spacing: float = 1.0) -> list[tuple[float, float]]:
    """The straight route cut into waypoints every ``spacing`` m, as the global planner resamples its
    paths (~1 m): training on it teaches the policy the near-waypoint observations a planned route gives."""
    (x0, y0), (x1, y1) = sc.start[:2], sc.goal
    n = max(1, int(np.ceil(np.hypot(x1 - x0, y1 - y0) / spacing)))
    return [(x0 + (x1 - x0) * k / n, y0 + (y1 - y0) * k / n) for k in range(1, n + 1)]


def _dense_mix(sc: Scenario):
    """Half the scenarios (decided by the scenario itself, so it is reproducible) get a dense route."""
    return dense_route(sc) if int(abs(sc.start[0]) * 1e6) % 2 else None


def waypoint_fn(planner: str) -> WaypointFn | None:
    """Routes for missions without their own waypoints.

    ``none``: straight to the goal; ``rrt``: the global planner over the known map (``cage_global_rrt``);
    ``rrt_current``: the same, keeping off the net wall the mean current is predicted to push in;
    ``dense``: straight, waypoints every metre; ``dense_mix``: half ``dense``, half ``none`` (training).
    """
    if planner == "none":
        return None
    if planner == "dense":
        return dense_route
    if planner == "dense_mix":
        return _dense_mix
    if planner not in RRT_NET_MODELS:
        raise ValueError(f"planner: expected one of {PLANNERS}, got {planner!r}")
    try:
        from cage_global_rrt.routes import RoutePlanner
    except ImportError as err:
        raise RuntimeError(f"planner rrt: cage_global_rrt is not installed ({err})") from None
    # The rrt_node's own options (its config/rrt.yaml), so offline routes are the graph's routes.
    return RoutePlanner(net_model=RRT_NET_MODELS[planner])


def episode_scenarios(spec: str, n: int, seed: int, wp_fn: WaypointFn | None = None,
                      start: int = 0) -> list[Scenario]:
    """Episodes ``start .. start+n-1`` of the evaluation set for ``seed``."""
    draw = sampler(spec)
    out = []
    for i in range(start, start + n):
        sc = draw(np.random.default_rng([seed, i]))
        if wp_fn is not None and not sc.waypoints:
            wps = wp_fn(sc)
            if wps is not None and len(wps):
                sc = sc.with_waypoints(wps)
        out.append(sc)
    return out
