"""Sea conditions: scenario families for domain randomisation and the evaluation matrix.

Why one module: the trainer's randomisation and the evaluator's matrix must draw their missions from
the same generator, or a policy is scored on conditions it never met in a different way than it met
them; both go through cage_sim's scenario families (``make_generator``), the simulator's one
definition of sea conditions. A ``Condition`` is one cell: current speed (m/s inside the pen, random
direction, slowly varying, the net deformed by it), obstacle size (``standard``: the cage's 0.3-2 m
obstacles; ``small``: circles of 0.15-0.3 m radius, between the study's 5 deg beams beyond ~2-3 m),
goal placement (``any``, or ``near_net``: 2.5 m from the net wall) and the number of fish schools
that flee the vehicle and close in again. Scenario names (usable wherever a scenario spec is, e.g. ``train
--scenario`` and ``evaluate --scenario``):

  sea:current=0.25,obstacles=small,goal=near_net,schools=3   one cell (keys optional; ``;`` also separates)
  sea_dr                                                     domain randomisation: each mission draws
                                                             current U(0, 0.5), small obstacles (50 %),
                                                             goal near the net (30 %), 0-3 schools
  sea_hard                                                   the hardest corner, oversampled in training

A matrix (``evaluate --matrix NAME``) is a list of cells; ``MATRICES`` holds the named ones.
"""
from __future__ import annotations

import itertools
import json
from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path

import numpy as np
from cage_sim.scenarios import Sampler, Scenario

OBSTACLES = ("standard", "small")
GOALS = ("any", "near_net")
NEAR_NET = 2.5          # m from the net wall the sonar sees: the "goal near the net" (cage_sim)


@dataclass(frozen=True)
class Condition:
    """One cell of the matrix (see the module docstring)."""

    current: float = 0.0
    obstacles: str = "standard"
    goal: str = "any"
    schools: int = 0

    def __post_init__(self) -> None:
        if not (0.0 <= self.current < 1.0):
            raise ValueError(f"current: {self.current!r} m/s must be in [0, 1) (the vehicle does 1 m/s)")
        if self.obstacles not in OBSTACLES:
            raise ValueError(f"obstacles: {self.obstacles!r} is not one of {OBSTACLES}")
        if self.goal not in GOALS:
            raise ValueError(f"goal: {self.goal!r} is not one of {GOALS}")
        if not (0 <= self.schools <= 6):
            raise ValueError(f"schools: {self.schools!r} must be 0-6")

    @property
    def name(self) -> str:
        return f"sea:current={self.current:g},obstacles={self.obstacles},goal={self.goal},schools={self.schools}"

    def sample(self, rng: np.random.Generator) -> Scenario:
        return sea_scenario(rng, self)


def parse_condition(spec: str) -> Condition:
    """``sea:current=0.25,obstacles=small`` (or ``;``-separated) -> Condition; errors name the key."""
    body = spec.split(":", 1)[1] if ":" in spec else ""
    kw: dict = {}
    for item in filter(None, (p.strip() for p in body.replace(";", ",").split(","))):
        key, eq, val = item.partition("=")
        if not eq:
            raise ValueError(f"{spec}: expected key=value, got {item!r}")
        if key == "current":
            kw[key] = float(val)
        elif key == "schools":
            kw[key] = int(val)
        elif key in ("obstacles", "goal"):
            kw[key] = val
        else:
            raise ValueError(f"{key}: unknown sea condition key (current, obstacles, goal, schools)")
    return Condition(**kw)


@lru_cache(maxsize=None)
def _generator(family: str) -> Sampler:
    from cage_sim.scenarios import make_generator
    return make_generator(family)


def family(c: Condition, current: str | None = None) -> str:
    """The cage_sim scenario family of a cell (``make_generator``: the same generator the simulator's
    own tests and the graph use): fleeing fish schools, a current field (``current`` m/s inside the
    pen, slowly varying by 20 %) that deforms the net, small obstacles, goal 2.5 m from the wall."""
    return (f"cage?current={current or format(c.current, 'g')}&obstacles={'small' if c.obstacles == 'small' else 'default'}"
            f"&goal={c.goal}&schools={c.schools}")


def sea_scenario(rng: np.random.Generator, c: Condition) -> Scenario:
    """A full-cage mission (20 known squares, 10 unknown obstacles) under condition ``c``."""
    return replace(_generator(family(c))(rng), name=c.name)


def domain_randomised(rng: np.random.Generator) -> Scenario:
    """``sea_dr``: every mission draws its own condition (see the module docstring)."""
    c = Condition(obstacles="small" if rng.random() < 0.5 else "standard",
                  goal="near_net" if rng.random() < 0.3 else "any", schools=int(rng.integers(0, 4)))
    return replace(_generator(family(c, "0-0.5"))(rng), name="sea_dr")


def hard(rng: np.random.Generator) -> Scenario:
    """``sea_hard``: strong current, small obstacles, goal near the net or schools."""
    c = Condition(obstacles="small", goal="near_net" if rng.random() < 0.5 else "any",
                  schools=int(rng.integers(0, 4)))
    return replace(_generator(family(c, "0.3-0.5"))(rng), name="sea_hard")


FAMILIES: dict[str, Sampler] = {"sea_dr": domain_randomised, "sea_hard": hard}


def family_sampler(name: str) -> Sampler | None:
    """The sampler for a sea family name or a ``sea:...`` cell, else None (not a sea name)."""
    if name in FAMILIES:
        return FAMILIES[name]
    if name == "sea" or name.startswith("sea:"):
        return parse_condition(name).sample
    return None


def grid(currents=(0.0, 0.25, 0.5), obstacles=OBSTACLES, goals=GOALS, schools=(0, 3)) -> list[Condition]:
    return [Condition(c, o, g, s) for c, o, g, s in itertools.product(currents, obstacles, goals, schools)]


MATRICES: dict[str, list[Condition]] = {
    "sea": grid(),                                                         # 24 cells
    "sea_small": grid(currents=(0.0, 0.5), goals=("any",), schools=(0,)) +  # 4 + 4 cells: the corners
    grid(currents=(0.25,), obstacles=("small",), goals=GOALS, schools=(0, 3)),
    "tiny": [Condition(), Condition(0.5, "small", "near_net", 1)],
    # beyond the training range (0-0.5 m/s): exposed sites ("0.5 m/s and more"), a hard and an easy cell
    "strong": [Condition(0.75, "small", "near_net", 3), Condition(0.75, "standard", "any", 0)],
}


# --------------------------------------------------------------------------- the evaluation matrix

def parse_cells(spec: str | None, n: int, flag: str = "--cells", what: str = "the matrix's cells") -> list[int]:
    """``0-3,6`` -> [0, 1, 2, 3, 6] (cell indices of an ``n``-cell matrix, or with ``flag`` and
    ``what`` other indices below ``n``: ``--only``'s missions); None or "" -> all."""
    if not spec:
        return list(range(n))
    out: list[int] = []
    for part in filter(None, (p.strip() for p in spec.split(","))):
        lo, dash, hi = part.partition("-")
        try:
            a, b = int(lo), int(hi) if dash else int(lo)
        except ValueError:
            raise ValueError(f"{flag}: {part!r} is not an index or a range like 0-3") from None
        if not 0 <= a <= b < n:
            raise ValueError(f"{flag}: {part!r} is outside {what} 0-{n - 1}")
        out += [k for k in range(a, b + 1) if k not in out]
    return out


def load_matrix(spec: str) -> tuple[str, list[Condition]]:
    """A named matrix (``MATRICES``) or a YAML file: a list of cells ``{current, obstacles, goal,
    schools}``, or a grid ``{currents: [...], obstacles: [...], goals: [...], schools: [...]}``."""
    if spec in MATRICES:
        return spec, MATRICES[spec]
    from pathlib import Path

    import yaml
    p = Path(spec)
    if not p.is_file():
        raise ValueError(f"matrix: {spec!r} is neither a named matrix ({', '.join(MATRICES)}) nor a file")
    data = yaml.safe_load(p.read_text())
    if isinstance(data, dict):
        bad = set(data) - {"currents", "obstacles", "goals", "schools"}
        if bad:
            raise ValueError(f"matrix {p}: unknown key(s) {sorted(bad)}")
        return p.stem, grid(**{k: tuple(v) for k, v in data.items()})
    if isinstance(data, list):
        cells = []
        for i, d in enumerate(data):
            try:
                cells.append(Condition(**d))
            except TypeError as err:
                raise ValueError(f"matrix {p}: cell {i}: {err}") from None
        return p.stem, cells
    raise ValueError(f"matrix {p}: expected a list of cells or a grid mapping")


def run_matrix(cells: list[Condition], drivers: dict, episodes: int, seed: int, planner: str = "rrt",
               env=None, progress: bool = False, replan: bool = False,
               skip: "set[tuple[int, str]] | frozenset" = frozenset(), grace: float = 0.0,
               failures: str | None = None, only: "list[int] | None" = None, known_map: bool = True,
               trace: list[dict] | None = None) -> list[dict]:
    """Every driver on the same ``episodes`` missions of every cell; one summary row per (cell, driver)
    not in ``skip`` (rows another run made, or cells another process runs).

    Cell ``k``'s missions come from seed ``[seed, k]`` (episode ``i``: ``default_rng([[seed, k], i])``
    in effect), so drivers meet identical missions and cells never share one, whichever cells a
    run does. ``grace``: see ``run_missions``; each row then counts its late goals (``late_goal``).
    Each row lists its failed episodes (``failed``: index, outcome, decisions), so two drivers can be
    compared mission by mission (``failure_overlap``). ``failures`` (a path prefix): the tracks of a
    cell and driver with any are plotted to ``<failures>_cell<k>_<driver>.png``. ``only``: just these
    missions of each cell (indices below ``episodes``), each the very mission of a full run.
    ``known_map``: a shield keeps clear of each mission's known map too (``run_missions``). ``trace``:
    a list that gets one row per decision of every mission flown, with its cell and driver."""
    from cage_sim.mission import EnvConfig

    from .evaluate import failed_episodes, plot_failures, replan_planner, run_missions, summarize
    env = env or EnvConfig()
    from .missions import waypoint_fn
    routes = waypoint_fn(planner)
    rows = []
    for k, cell in enumerate(cells):
        todo = {d: v for d, v in drivers.items() if (k, d) not in skip}
        if not todo:
            continue
        scs, indices = [], sorted(only) if only else list(range(episodes))
        for i in indices:
            sc = cell.sample(np.random.default_rng([seed, k, i]))
            if routes is not None:
                wps = routes(sc)
                if wps is not None and len(wps):
                    sc = sc.with_waypoints(wps)
            scs.append(sc)
        for dname, drv in todo.items():
            flown: list[dict] | None = [] if trace is not None else None
            res = run_missions(drv, scs, env, keep_tracks=len(scs) if failures else 0, progress=progress,
                               replan=replan_planner(routes, replan), grace=grace, indices=indices,
                               known_map=known_map, trace=flown)
            if trace is not None:
                trace += [{"cell": k, "driver": dname, **row} for row in flown]
            s = summarize(res, grace)
            if failures:
                plot_failures(f"{failures}_cell{k}_{dname}.png", dict(zip(indices, scs)), res,
                              f"cell {k} {cell.name}, {dname}")
            rows.append({"cell": k, "sensor": env.sonar.profile, "current": cell.current, "obstacles": cell.obstacles, "goal_at": cell.goal,
                         "schools": cell.schools, "driver": dname, **{f"{o}": s["counts"][o] for o in s["counts"]},
                         "episodes": s["episodes"], "ci95": s["ci95"], "mean_steps": s["mean_steps"],
                         "replans": s["replans"], **({"late_goal": s["late"]["goal"]} if grace else {}),
                         "failed": failed_episodes(res)})
            if progress:
                print(f"cell {k} {cell.name} {dname}: " + " ".join(
                    f"{o} {100 * s['rates'][o]:.1f}%" for o in s["rates"]), flush=True)
    return rows


def _pct(k: int, n: int) -> str:
    from .evaluate import wilson
    lo, hi = wilson(k, n)
    return f"{100 * k / n:.1f} [{100 * lo:.1f}, {100 * hi:.1f}]"


def markdown(rows: list[dict], title: str) -> str:
    """The matrix as a markdown table: goal and collision % with 95 % Wilson intervals per driver."""
    drivers = list(dict.fromkeys(r["driver"] for r in rows))
    late = any("late_goal" in r for r in rows)   # a run with a grace: timeouts that reach the goal later
    head = "| current m/s | obstacles | goal | schools | " + " | ".join(
        f"{d}: goal % | {d}: collision %" + (f" | {d}: late goals" if late else "") for d in drivers) + " |"
    lines = [f"### {title}", "", head, "|" + "---|" * (4 + (2 + late) * len(drivers))]
    for k in dict.fromkeys(r["cell"] for r in rows):
        rs = {r["driver"]: r for r in rows if r["cell"] == k}
        r0 = next(iter(rs.values()))
        cells = [f"{r0['current']:g}", r0["obstacles"], r0["goal_at"], str(r0["schools"])]
        for d in drivers:   # a merged part may lack a driver's row in some cells
            r = rs.get(d)
            cells += [_pct(r["goal"], r["episodes"]), _pct(r["collision"], r["episodes"])] if r else ["-", "-"]
            if late:
                cells.append(str(r.get("late_goal", "-")) if r else "-")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def driver_rows(spec: str) -> tuple[str, dict, list[dict]]:
    """``PATH:DRIVER`` -> (path, the matrix JSON ``evaluate --matrix`` wrote, its rows of that
    driver). What the tools that read those files back (``failure_overlap``, ``mission_sets``)
    share; a bad spec, an unreadable file or a driver the file lacks is a ``ValueError`` naming it."""
    path, sep, driver = spec.rpartition(":")
    if not sep or not path or not driver:
        raise ValueError(f"{spec}: expected PATH:DRIVER (e.g. runs/m.json:shield)")
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, ValueError) as err:
        raise ValueError(f"{path}: not a readable matrix JSON ({err})") from None
    rows = [r for r in data.get("rows", []) if r.get("driver") == driver]
    if not rows:
        have = sorted({str(r.get("driver")) for r in data.get("rows", [])})
        raise ValueError(f"{path}: no {driver!r} rows (drivers there: {', '.join(have) or 'none'})")
    return path, data, rows


def emit(text: str, out: str | None, head: str = "") -> None:
    """Print a table the file readers made (``failure_overlap``, ``mission_sets``, ``cell_compare``)
    and, with ``out``, write it there too, after ``head`` (folders made as needed)."""
    print(text, end="")
    if out:
        Path(out).parent.mkdir(parents=True, exist_ok=True)
        Path(out).write_text(head + text)


def write_csv(rows: list[dict], path) -> None:
    import csv

    from .evaluate import wilson
    cols = ["cell", "current", "obstacles", "goal_at", "schools", "driver", "episodes", "goal_n", "collision_n",
            "wander_n", "timeout_n", "goal_pct", "goal_lo", "goal_hi", "collision_pct", "collision_lo", "collision_hi"]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for r in rows:
            n = r["episodes"]
            g, c = wilson(r["goal"], n), wilson(r["collision"], n)
            w.writerow([r["cell"], r["current"], r["obstacles"], r["goal_at"], r["schools"], r["driver"], n,
                        r["goal"], r["collision"], r["wander"], r["timeout"],
                        round(100 * r["goal"] / n, 2), round(100 * g[0], 2), round(100 * g[1], 2),
                        round(100 * r["collision"] / n, 2), round(100 * c[0], 2), round(100 * c[1], 2)])


def plot(rows: list[dict], path, title: str) -> None:
    """Goal and collision rates per cell, drivers side by side, with 95 % Wilson intervals."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .evaluate import wilson
    drivers = list(dict.fromkeys(r["driver"] for r in rows))
    cells = list(dict.fromkeys(r["cell"] for r in rows))
    labels = []
    for k in cells:
        r = next(r for r in rows if r["cell"] == k)
        labels.append(f"{r['current']:g} m/s, {r['obstacles']}, goal {r['goal_at']}, {r['schools']} sch.")
    fig, axes = plt.subplots(1, 2, figsize=(14, 0.42 * len(cells) + 1.8), sharey=True)
    width = 0.8 / len(drivers)
    for ax, outcome in zip(axes, ("goal", "collision")):
        for j, d in enumerate(drivers):
            rs = [next(r for r in rows if r["cell"] == k and r["driver"] == d) for k in cells]
            p = np.array([100 * r[outcome] / r["episodes"] for r in rs])
            ci = np.array([wilson(r[outcome], r["episodes"]) for r in rs]) * 100
            y = np.arange(len(cells)) + (j - (len(drivers) - 1) / 2) * width
            ax.barh(y, p, height=width, label=d, xerr=[p - ci[:, 0], ci[:, 1] - p], capsize=2)
        ax.set_title(f"{outcome} % (95 % Wilson)")
        ax.grid(axis="x", alpha=0.3)
    axes[0].set_yticks(np.arange(len(cells)), labels, fontsize=8)
    axes[0].invert_yaxis()
    axes[1].legend(loc="lower right", fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
