"""Pictures of the cage, routes and tracks (matplotlib, headless)."""
from __future__ import annotations

import math
from typing import Iterable, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .world import World  # noqa: E402

OUTCOME_COLOURS = {"goal": "tab:green", "collision": "tab:red", "wander": "tab:orange", "timeout": "tab:purple"}


def draw_world(ax, world: World, t: float = 0.0) -> None:
    """Net (the nominal circle dashed when the current deforms it: the map's net vs the real one),
    obstacles, fish schools where they are in this snapshot, and the current's mean vector."""
    if world.net.deformed:
        ax.add_patch(plt.Circle((0, 0), world.net_radius, fill=False, lw=1, ls="--", color="navy",
                                label="net on the map"))
        ax.add_patch(plt.Polygon(world.net.polygon, closed=True, fill=False, lw=2, color="navy",
                                 label=f"net ({world.net.loss:.0%} area lost)"))
    else:
        ax.add_patch(plt.Circle((0, 0), world.net_radius, fill=False, lw=2, color="navy", label="net"))
    for i, (cx, cy, r) in enumerate(world.fish_circles):
        ax.add_patch(plt.Circle((cx, cy), r, color="tab:cyan", alpha=0.6, label="fish school" if i == 0 else None))
    if any(world.current):
        s = 20.0 / max(world.current_field.max_speed, 1e-9)   # the arrow's length is not to scale
        ax.annotate("", xy=(-world.net_radius * 0.8 + world.current[0] * s * 0.3,
                            world.net_radius * 0.9 + world.current[1] * s * 0.3),
                    xytext=(-world.net_radius * 0.8, world.net_radius * 0.9),
                    arrowprops={"arrowstyle": "->", "color": "tab:blue"})
        ax.text(-world.net_radius * 0.8, world.net_radius * 0.97, f"current {math.hypot(*world.current):.2f} m/s",
                fontsize=7, color="tab:blue")
    for group, colour, label in ((world.known, "dimgray", "known obstacle"),
                                 (world.unknown, "tab:brown", "unknown obstacle")):
        for i, ob in enumerate(group):
            cx, cy = ob.centre(t)
            lab = label if i == 0 else None
            if ob.shape == "square":
                h = ob.size / 2
                ax.add_patch(plt.Rectangle((cx - h, cy - h), ob.size, ob.size, color=colour, label=lab))
            else:
                ax.add_patch(plt.Circle((cx, cy), ob.size, color=colour, label=lab))
            if ob.moving:
                ax.plot([ob.x - ob.ax, ob.x + ob.ax], [ob.y - ob.ay, ob.y + ob.ay], ":", color=colour)
    r = world.net_radius * 1.05
    ax.set_xlim(-r, r)
    ax.set_ylim(-r, r)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")


def draw_track(ax, track: Sequence[Sequence[float]], outcome: str | None, label: str | None = None,
               alpha: float = 1.0) -> None:
    tr = np.asarray(track)
    ax.plot(tr[:, 0], tr[:, 1], "-", color=OUTCOME_COLOURS.get(outcome or "", "k"), lw=1.5, alpha=alpha,
            label=label)


def plot_episode(path: str, world: World, track, outcome: str | None, start, goal,
                 route: Iterable | None = None, title: str = "") -> None:
    fig, ax = plt.subplots(figsize=(7, 7))
    draw_world(ax, world)
    if route is not None:
        rt = np.vstack([np.asarray(start[:2])[None], np.asarray(list(route))])
        ax.plot(rt[:, 0], rt[:, 1], "--o", ms=3, color="tab:blue", lw=1, label="route")
    draw_track(ax, track, outcome, label=f"track ({outcome})")
    ax.plot(*start[:2], "k^", ms=9, label="start")
    ax.plot(*goal, "r*", ms=14, label="goal")
    ax.set_title(title)
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def render_rgb(mission) -> np.ndarray:
    """The env's ``rgb_array`` frame."""
    fig, ax = plt.subplots(figsize=(5, 5), dpi=80)
    draw_world(ax, mission.scene, mission.t)
    draw_track(ax, mission.track, mission.outcome)
    x, y, yaw = mission.pose
    ax.arrow(x, y, 1.5 * math.cos(yaw), 1.5 * math.sin(yaw), width=0.3, color="k")
    fig.canvas.draw()
    img = np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()
    plt.close(fig)
    return img


def plot_profiles(path: str, scenario, pose=None, seed: int = 0) -> None:
    """One panel per sensor profile: what each sonar returns from ``pose`` (default: the scenario's start)
    in the scenario's world. Beams with a return are drawn to it; the scanning panel colours them by age
    (the head has swept for 2 s since its first sweep), which is what its LaserScan carries."""
    from .sonar import PROFILE_NAMES, make_sonar
    world = scenario.world
    x, y, yaw = pose if pose is not None else scenario.start
    fig, axes = plt.subplots(1, len(PROFILE_NAMES), figsize=(5 * len(PROFILE_NAMES), 5))
    for ax, name in zip(axes, PROFILE_NAMES):
        s = make_sonar(name)
        rng = np.random.default_rng(seed)
        head = s.head()
        head.reset(world, x, y, yaw, 0.0, rng)
        scan = head.update(world, x, y, yaw, 2.0, rng) if s.mechanical else head.last
        draw_world(ax, world)
        ages = scan.ages(2.0 if s.mechanical else 0.0)
        for r, a, age in zip(scan.ranges, scan.angles, ages):
            hit = np.isfinite(r)
            rr = r if hit else s.max_range
            colour = plt.cm.viridis(min(age / max(s.sweep_time, 1e-9), 1.0)) if s.mechanical else \
                ("tab:red" if hit else "0.85")
            ax.plot([x, x + rr * math.cos(yaw + a)], [y, y + rr * math.sin(yaw + a)], "-", lw=0.6,
                    color=colour, alpha=1.0 if hit else 0.5)
            if hit:
                ax.plot(x + r * math.cos(yaw + a), y + r * math.sin(yaw + a), ".", ms=3, color="k")
        ax.plot(x, y, "k^", ms=8)
        w = math.degrees(s.beam_width)
        ax.set_title(f"{name}: {s.n_beams} beams, {math.degrees(s.fov):.0f} deg, width {w:.1f} deg"
                     + (f", sweep {s.sweep_time:.0f} s" if s.mechanical else ""), fontsize=9)
        lim = s.max_range + 2
        ax.set_xlim(x - lim, x + lim)
        ax.set_ylim(y - lim, y + lim)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
