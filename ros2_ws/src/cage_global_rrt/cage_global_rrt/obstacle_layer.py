"""A map that learns: sonar returns confirmed over several scans become temporary obstacles.

Why: the global planner only knows the map, so a replan after the vehicle met an unknown obstacle
used to draw the same route straight back through it. The layer keeps evidence per grid cell in
the map frame: a cell hit in ``confirm_scans`` scans is confirmed; confirmed cells that touch are
clustered into one circle (centre = mean return, radius = farthest return + ``pad``, since returns
lie on the near surface). Evidence decays by looking: a cell whose beam passed through it without
a return (the sonar saw open water there) collects a miss, and ``forget_scans`` misses in a row
remove it; a fish school that swims off is forgotten once the sonar looks again. Returns explained
by the known map (within ``known_tolerance`` of a known obstacle, within ``net_tolerance`` of the
net) are ignored: the planner knows those already.

Pure NumPy, no ROS: ``rrt_node`` feeds it scans + odometry and ``routes.RoutePlanner`` /
``benchmarks/bench_obstacle_layer.py`` feed it simulated scans, through the same ``update``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from cage_sim.world import Obstacle

from .known_map import KnownMap
from .planner import GlobalPlanner, PlanResult


@dataclass(frozen=True)
class LayerParams:
    """Knobs of the obstacle layer (the node's ``layer_*`` parameters)."""

    cell: float = 1.0              # m, grid cell for evidence
    confirm_scans: int = 3         # scans with a return in a cell before it is an obstacle
    forget_scans: int = 3          # scans seeing through a cell, in a row, before it is dropped
    stale_scans: int = 20          # unconfirmed cells not hit for this many scans are dropped
    pad: float = 0.5               # m added to a cluster's radius (returns lie on its near side)
    known_tolerance: float = 0.75  # m: returns this close to a known obstacle are the map's
    net_tolerance: float = 1.5     # m: returns this close to (or beyond) the nominal net are the net's

    @classmethod
    def from_parameters(cls, values: dict) -> "LayerParams":
        """From the node's ``layer_*`` parameters (the rest keep their defaults)."""
        return cls(confirm_scans=int(values.get("layer_confirm_scans", cls.confirm_scans)),
                   forget_scans=int(values.get("layer_forget_scans", cls.forget_scans)))

    def error(self) -> str | None:
        for name in ("cell", "pad", "known_tolerance", "net_tolerance"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0) or (name == "cell" and v <= 0):
                return f"layer {name} must be a number {'> 0' if name == 'cell' else '>= 0'}, got {v!r}"
        for name in ("confirm_scans", "forget_scans", "stale_scans"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                return f"layer {name} must be an integer >= 1, got {v!r}"
        return None


@dataclass
class _Cell:
    hits: int = 0          # scans with a return in the cell
    misses: int = 0        # scans in a row that saw through it
    last_hit: int = 0      # scan number of the last return
    sx: float = 0.0        # sum of return positions (for the mean)
    sy: float = 0.0
    n: int = 0             # returns summed


@dataclass
class ObstacleLayer:
    """Evidence grid over one known map; ``obstacles()`` are the confirmed clusters as circles."""

    known: KnownMap
    params: LayerParams = field(default_factory=LayerParams)
    cells: dict = field(default_factory=dict)
    scans: int = 0
    version: int = 0       # bumps whenever the set of obstacles may have changed

    def __post_init__(self) -> None:
        err = self.params.error()
        if err:
            raise ValueError(err)

    def reset(self, known: KnownMap | None = None) -> None:
        if known is not None:
            self.known = known
        self.cells.clear()
        self.scans = 0
        self.version += 1

    # ------------------------------------------------------------------ evidence

    def update(self, pose, ranges, angles, max_range: float) -> None:
        """One scan: ``ranges`` (m, inf = no echo) along body ``angles`` from ``pose`` (x, y, yaw)
        in the map frame. Non-finite poses are ignored (a logged fallback is the caller's)."""
        x, y, yaw = (float(v) for v in pose[:3])
        if not all(math.isfinite(v) for v in (x, y, yaw)):
            return
        ranges = np.asarray(ranges, dtype=float)
        angles = np.asarray(angles, dtype=float)
        self.scans += 1
        hit = np.isfinite(ranges) & (ranges > 0) & (ranges < max_range)
        a = yaw + angles[hit]
        px, py = x + ranges[hit] * np.cos(a), y + ranges[hit] * np.sin(a)
        keep = self._unexplained(px, py)
        px, py = px[keep], py[keep]
        c = self.params.cell
        seen = set()
        was = self._confirmed_keys()
        for qx, qy in zip(px, py):
            key = (int(math.floor(qx / c)), int(math.floor(qy / c)))
            cell = self.cells.get(key)
            if cell is None:
                cell = self.cells[key] = _Cell()
            if key not in seen:
                seen.add(key)
                cell.hits += 1
                cell.misses = 0
                cell.last_hit = self.scans
            cell.sx += qx
            cell.sy += qy
            cell.n += 1
        self._decay(x, y, yaw, ranges, angles, max_range, seen)
        if self._confirmed_keys() != was:
            self.version += 1

    def _unexplained(self, px: np.ndarray, py: np.ndarray) -> np.ndarray:
        """Mask of returns the known map does not explain."""
        k, p = self.known, self.params
        keep = np.hypot(px, py) < k.net_radius - p.net_tolerance
        for cx, cy, h in k.squares:
            dx = np.maximum(np.abs(px - cx) - h, 0.0)
            dy = np.maximum(np.abs(py - cy) - h, 0.0)
            keep &= np.hypot(dx, dy) > p.known_tolerance
        for cx, cy, r in k.circles:
            keep &= np.hypot(px - cx, py - cy) - r > p.known_tolerance
        return keep

    def _decay(self, x, y, yaw, ranges, angles, max_range, seen) -> None:
        """A miss for every cell the sonar looked through without a return; drop stale cells."""
        p = self.params
        if len(angles) > 1:
            inc = float(np.median(np.abs(np.diff(angles))))
        else:
            inc = 2.0 * math.pi
        drop = []
        for key, cell in self.cells.items():
            if key in seen:
                continue
            if cell.hits < p.confirm_scans and self.scans - cell.last_hit >= p.stale_scans:
                drop.append(key)
                continue
            cx, cy = cell.sx / cell.n, cell.sy / cell.n
            d = math.hypot(cx - x, cy - y)
            if d >= max_range:
                continue
            rel = np.abs(np.remainder(math.atan2(cy - y, cx - x) - yaw - angles + math.pi, 2 * math.pi) - math.pi)
            b = int(np.argmin(rel))
            if rel[b] > 0.5 * inc + 1e-9:
                continue          # outside the sonar's sector
            if ranges[b] > d + 0.5 * p.cell * math.sqrt(2.0):   # the beam passed through the cell
                cell.misses += 1
                if cell.misses >= p.forget_scans:
                    drop.append(key)
        for key in drop:
            del self.cells[key]

    def _confirmed_keys(self) -> frozenset:
        n = self.params.confirm_scans
        return frozenset(k for k, c in self.cells.items() if c.hits >= n)

    # ------------------------------------------------------------------ obstacles

    def obstacles(self) -> list[Obstacle]:
        """Confirmed cells clustered (8-connected) into circles."""
        keys = self._confirmed_keys()
        todo, out = set(keys), []
        while todo:
            stack = [todo.pop()]
            group = []
            while stack:
                k = stack.pop()
                group.append(k)
                for dx in (-1, 0, 1):
                    for dy in (-1, 0, 1):
                        nb = (k[0] + dx, k[1] + dy)
                        if nb in todo:
                            todo.remove(nb)
                            stack.append(nb)
            pts = np.array([(self.cells[k].sx / self.cells[k].n, self.cells[k].sy / self.cells[k].n) for k in group])
            centre = pts.mean(axis=0)
            radius = float(np.hypot(*(pts - centre).T).max()) + 0.5 * self.params.cell + self.params.pad
            out.append(Obstacle("circle", float(centre[0]), float(centre[1]), radius))
        out.sort(key=lambda o: (o.x, o.y))
        return out

    def exit_point(self, pose, clearance: float) -> tuple[float, float]:
        """Where a vehicle that stopped next to a confirmed obstacle (closer than the clearance to
        its circle) should start the replan: pushed straight away from the circle's centre to
        ``clearance`` (+1 cm) outside it. The move only increases the distance to that obstacle, so
        the replan keeps the obstacles at full size instead of shrinking them around the vehicle."""
        x, y = float(pose[0]), float(pose[1])
        for _ in range(3):   # a push out of one circle can land in a neighbour's margin
            moved = False
            for ob in self.obstacles():
                d = math.hypot(x - ob.x, y - ob.y)
                need = ob.size + clearance + 0.01
                if d < need:
                    ux, uy = ((x - ob.x) / d, (y - ob.y) / d) if d > 1e-9 else (1.0, 0.0)
                    x, y = ob.x + need * ux, ob.y + need * uy
                    moved = True
            if not moved:
                break
        return x, y

    def planning_map(self, free=(), clearance: float = 0.0) -> KnownMap:
        """The known map plus the layer's circles. A circle is shrunk (or dropped) so that every
        point in ``free`` (the vehicle's pose, the goal) keeps ``clearance``: a vehicle next to a
        return must still be able to plan away from it."""
        circles = []
        for ob in self.obstacles():
            r = ob.size
            for p in free:
                r = min(r, math.hypot(p[0] - ob.x, p[1] - ob.y) - clearance - 1e-3)
            if r >= 0.25:
                circles.append(Obstacle("circle", ob.x, ob.y, r))
        k = self.known
        known = [Obstacle("square", x, y, 2.0 * h) for x, y, h in k.squares]
        known += [Obstacle("circle", x, y, r) for x, y, r in k.circles]
        return KnownMap.from_obstacles(k.net_radius, known + circles)


def plan_with_layer(planner: GlobalPlanner, layer: ObstacleLayer | None, pose, goal) -> PlanResult:
    """A (re)plan that uses the layer: leave a confirmed obstacle the vehicle stopped next to
    (``exit_point``), plan on the known map plus the layer, and prepend the vehicle's position.
    ``layer`` None plans on the layer's known map alone (the same as before the layer existed).
    The node and the offline evaluation both call this."""
    if layer is None:
        return planner.plan(pose, goal)
    clearance = planner.options.clearance
    exit_ = layer.exit_point(pose, clearance)
    if not layer.obstacles():
        if planner.kmap is not layer.known:
            planner.set_map(layer.known)   # nothing learnt: the known map itself (setup kept)
        return planner.plan(pose, goal)
    planner.set_map(layer.planning_map(free=(exit_, goal), clearance=clearance))
    moved = math.hypot(exit_[0] - pose[0], exit_[1] - pose[1]) > 1e-9
    res = planner.plan(exit_, goal) if moved else planner.plan(pose, goal)  # pose keeps a Dubins heading
    if not res.ok:
        # the learnt obstacles close every way (or the exit lands on the known map): plan as before
        # the layer existed rather than not at all; the message says so
        layered = res.status.name
        planner.set_map(layer.known)
        res = planner.plan(pose, goal)
        res.message += f" (on the known map only: with the obstacle layer {layered})"
        return res
    if moved:
        head = np.array([[float(pose[0]), float(pose[1])]])
        yaw = math.atan2(exit_[1] - pose[1], exit_[0] - pose[0])
        res.waypoints = np.vstack((head, res.waypoints))
        res.headings = np.concatenate(([yaw], res.headings))
        res.length += math.hypot(exit_[0] - pose[0], exit_[1] - pose[1])
    return res
