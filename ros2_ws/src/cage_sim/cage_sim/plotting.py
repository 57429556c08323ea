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
