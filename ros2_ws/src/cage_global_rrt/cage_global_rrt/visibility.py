"""Shortest paths under the clearance: a reduced visibility graph over polygons circumscribing
the inflated obstacles (``planner: optimal``).

Why circumscribed polygons: a published path is a polyline, and a polyline that wraps a rounded
obstacle must stay outside it, so its corners sit on a polygon around the arc, not on the arc. Each
inflated obstacle (a square grown by the clearance with rounded corners, a grown circle) is
replaced by a convex polygon whose edges are tangent to it from outside (``ARC_SEGMENTS`` per
quarter turn). Graph edges are tested with the exact segment kernel (``geometry.segment_valid``),
not against the polygons, so an edge may cut between polygon and arc: every edge keeps the full
clearance, and the result is never longer than the shortest path among the polygons, which is
within a factor 1/cos(pi / (4 * ARC_SEGMENTS)) of the true optimum on the wrapped arcs only
(1.0048 at 8 segments; measured over whole paths in benchmarks/bench_rrt.py).

Why "reduced": a shortest path only bends at a vertex where it wraps the polygon, so only edges
tangent to the polygons at both ends are kept (and, per query, only the start's and goal's tangent
vertices are tried). The graph is built once per (map, clearance) and cached by the map's
content; a query is a few hundred exact segment tests plus A* in compiled code (tens of us).

The net: the free disc of radius R - clearance is convex, so a segment between two points inside
it stays inside; vertices outside it are dropped.
"""
from __future__ import annotations

import heapq
import math
from collections import OrderedDict

import numpy as np

from .geometry import _jit, point_valid, segment_valid
from .known_map import KnownMap

ARC_SEGMENTS = 8        # tangent edges per quarter turn of a rounded corner
CIRCLE_SEGMENTS = 32    # tangent edges around a circular obstacle
OUTSET = 1e-6           # polygon edges sit this far outside the inflated obstacle (float safety)
_CACHE_SIZE = 64


def circumscribed_polygons(kmap: KnownMap, margin: float, arc_segments: int = ARC_SEGMENTS,
                           circle_segments: int = CIRCLE_SEGMENTS) -> list[np.ndarray]:
    """Convex CCW polygons containing each inflated obstacle, edges tangent to it."""
    m = margin + OUTSET
    polys = []
    d = 0.5 * math.pi / arc_segments
    rv = m / math.cos(0.5 * d)   # vertex radius of a polygon whose edges touch the arc
    for cx, cy, h in kmap.squares:
        pts = []
        for k, (sx, sy) in enumerate(((1, -1), (1, 1), (-1, 1), (-1, -1))):
            base = -0.5 * math.pi + k * 0.5 * math.pi
            for j in range(arc_segments):
                a = base + (j + 0.5) * d
                pts.append((cx + sx * h + rv * math.cos(a), cy + sy * h + rv * math.sin(a)))
        polys.append(np.asarray(pts))
    dc = 2.0 * math.pi / circle_segments
    for cx, cy, r in kmap.circles:
        rr = (r + m) / math.cos(0.5 * dc)
        polys.append(np.asarray([(cx + rr * math.cos((j + 0.5) * dc), cy + rr * math.sin((j + 0.5) * dc))
                                 for j in range(circle_segments)]))
    return polys


@_jit
def _tangent(px, py, vx, vy, ax, ay, bx, by):
    """Line p-v supports the polygon at v: its neighbours a and b are not on opposite sides."""
    dx = vx - px
    dy = vy - py
    tol = 1e-9 * (abs(dx) + abs(dy))
    ca = dx * (ay - py) - dy * (ax - px)
    cb = dx * (by - py) - dy * (bx - px)
    return not ((ca > tol and cb < -tol) or (ca < -tol and cb > tol))


@_jit
def _build(verts, prv, nxt, valid, net_radius, margin, squares, circles):
    """CSR adjacency (indptr, indices, weights) of the reduced visibility graph."""
    n = verts.shape[0]
    ei = np.empty(n * 16, dtype=np.int64)
    ej = np.empty(n * 16, dtype=np.int64)
    cap = ei.shape[0]
    m = 0
    for i in range(n):
        if not valid[i]:
            continue
        xi = verts[i, 0]
        yi = verts[i, 1]
        for j in range(i + 1, n):
            if not valid[j]:
                continue
            xj = verts[j, 0]
            yj = verts[j, 1]
            if not _tangent(xj, yj, xi, yi, verts[prv[i], 0], verts[prv[i], 1], verts[nxt[i], 0], verts[nxt[i], 1]):
                continue
            if not _tangent(xi, yi, xj, yj, verts[prv[j], 0], verts[prv[j], 1], verts[nxt[j], 0], verts[nxt[j], 1]):
                continue
            if not segment_valid(xi, yi, xj, yj, net_radius, margin, squares, circles):
                continue
            if m + 2 > cap:
                ei2 = np.empty(2 * cap, dtype=np.int64)
                ej2 = np.empty(2 * cap, dtype=np.int64)
                ei2[:m] = ei[:m]
                ej2[:m] = ej[:m]
                ei, ej, cap = ei2, ej2, 2 * cap
            ei[m] = i
            ej[m] = j
            ei[m + 1] = j
            ej[m + 1] = i
            m += 2
    counts = np.zeros(n + 1, dtype=np.int64)
    for e in range(m):
        counts[ei[e] + 1] += 1
    indptr = np.cumsum(counts)
    fill = indptr[:-1].copy()
    indices = np.empty(m, dtype=np.int64)
    weights = np.empty(m, dtype=np.float64)
    for e in range(m):
        k = fill[ei[e]]
        fill[ei[e]] += 1
        indices[k] = ej[e]
        weights[k] = math.hypot(verts[ei[e], 0] - verts[ej[e], 0], verts[ei[e], 1] - verts[ej[e], 1])
    return indptr, indices, weights


@_jit
def _astar(sx, sy, gx, gy, verts, prv, nxt, valid, prune, indptr, indices, weights,
           net_radius, margin, end_margin, squares, circles):
    """A* from start to goal over the graph plus the start's and goal's edges. The Euclidean
    distance to the goal is a consistent heuristic. The endpoints' edges are tested lazily: a start
    edge when its heap entry comes up (entries ``n + i``), a goal edge when it could improve the
    best path, so a query tests a few dozen segments, not one per vertex. Returns (length, chain)."""
    n = verts.shape[0]
    dist = np.full(n, np.inf)
    prev = np.full(n, -1, dtype=np.int64)
    done = np.zeros(n, dtype=np.bool_)
    h = np.empty(n)
    for i in range(n):
        h[i] = math.hypot(verts[i, 0] - gx, verts[i, 1] - gy)
    heap = [(0.0, np.int64(-1))]
    heap.pop()
    for i in range(n):
        if not valid[i]:
            continue
        if prune and not _tangent(sx, sy, verts[i, 0], verts[i, 1], verts[prv[i], 0], verts[prv[i], 1],
                                  verts[nxt[i], 0], verts[nxt[i], 1]):
            continue
        heapq.heappush(heap, (math.hypot(verts[i, 0] - sx, verts[i, 1] - sy) + h[i], np.int64(n + i)))
    best = np.inf
    last = -1
    while len(heap) > 0:
        f, e = heapq.heappop(heap)
        if f >= best:
            break
        if e >= n:   # a start edge, not yet tested
            i = e - n
            if done[i]:
                continue
            if not segment_valid(sx, sy, verts[i, 0], verts[i, 1], net_radius, end_margin, squares, circles):
                continue
            d = f - h[i]
            if d >= dist[i]:
                continue
            dist[i] = d
            prev[i] = -1
        else:
            i = e
            if done[i]:
                continue
        done[i] = True
        d = dist[i]
        if d + h[i] < best and (not prune or _tangent(gx, gy, verts[i, 0], verts[i, 1], verts[prv[i], 0],
                                                      verts[prv[i], 1], verts[nxt[i], 0], verts[nxt[i], 1])):
            if segment_valid(verts[i, 0], verts[i, 1], gx, gy, net_radius, end_margin, squares, circles):
                best = d + h[i]
                last = i
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            nd = d + weights[k]
            if nd < dist[j]:
                dist[j] = nd
                prev[j] = i
                heapq.heappush(heap, (nd + h[j], j))
    count = 0
    i = last
    while i >= 0:
        count += 1
        i = prev[i]
    chain = np.empty(count, dtype=np.int64)
    i = last
    while i >= 0:
        count -= 1
        chain[count] = i
        i = prev[i]
    return best, chain


class OptimalGraph:
    """The reduced visibility graph of one (map, clearance): built once, queried many times."""

    def __init__(self, kmap: KnownMap, margin: float, arc_segments: int = ARC_SEGMENTS,
                 circle_segments: int = CIRCLE_SEGMENTS) -> None:
        self.kmap, self.margin = kmap, float(margin)
        polys = circumscribed_polygons(kmap, margin, arc_segments, circle_segments)
        sizes = [len(p) for p in polys]
        self.verts = np.ascontiguousarray(np.vstack(polys) if polys else np.zeros((0, 2)), dtype=np.float64)
        starts = np.cumsum([0] + sizes)[:-1]
        self.prv = np.concatenate([s + (np.arange(k) - 1) % k for s, k in zip(starts, sizes)]).astype(np.int64) \
            if polys else np.zeros(0, dtype=np.int64)
        self.nxt = np.concatenate([s + (np.arange(k) + 1) % k for s, k in zip(starts, sizes)]).astype(np.int64) \
            if polys else np.zeros(0, dtype=np.int64)
        k = kmap
        self.valid = np.array([point_valid(x, y, k.net_radius, self.margin, k.squares, k.circles)
                               for x, y in self.verts], dtype=np.bool_)
        self.indptr, self.indices, self.weights = _build(self.verts, self.prv, self.nxt, self.valid,
                                                         k.net_radius, self.margin, k.squares, k.circles)

    @property
    def edges(self) -> int:
        return len(self.indices) // 2

    def shortest_path(self, start, goal, endpoint_margin: float | None = None) -> tuple[float, np.ndarray]:
        """(length, (N, 2) polyline from start to goal); (inf, empty) when the goal is unreachable.
        Start and goal must be free points (clearance >= margin); that is the caller's check.
        ``endpoint_margin`` (<= the graph's margin) tests the first and last legs at a smaller
        clearance: the flyable mode plans on a graph grown beyond the clearance but must still
        leave a start that is only ``clearance`` from an obstacle."""
        k = self.kmap
        m = self.margin if endpoint_margin is None else min(float(endpoint_margin), self.margin)
        sx, sy, gx, gy = float(start[0]), float(start[1]), float(goal[0]), float(goal[1])
        if segment_valid(sx, sy, gx, gy, k.net_radius, self.margin, k.squares, k.circles):
            return math.hypot(gx - sx, gy - sy), np.array([[sx, sy], [gx, gy]])
        for prune in (True, False):
            # unpruned retry: a point closer to an obstacle than its polygon (inside the polygon's
            # sliver around the arc) has no tangent vertex on that polygon
            best, chain = _astar(sx, sy, gx, gy, self.verts, self.prv, self.nxt, self.valid, prune,
                                 self.indptr, self.indices, self.weights, k.net_radius, self.margin, m,
                                 k.squares, k.circles)
            if math.isfinite(best):
                return best, np.vstack(([sx, sy], self.verts[chain], [gx, gy]))
        return math.inf, np.zeros((0, 2))

    def shortest(self, start, goal) -> float:
        return self.shortest_path(start, goal)[0]


_GRAPHS: "OrderedDict[tuple, OptimalGraph]" = OrderedDict()


def optimal_graph(kmap: KnownMap, margin: float, arc_segments: int = ARC_SEGMENTS) -> OptimalGraph:
    """The graph for this map content and margin, built on first use and kept (LRU, 64 maps): the
    evaluator plans many routes per cage with fresh planners, the node replans on one map."""
    key = (kmap.net_radius, kmap.squares.tobytes(), kmap.circles.tobytes(), float(margin), arc_segments)
    g = _GRAPHS.get(key)
    if g is None:
        g = OptimalGraph(kmap, margin, arc_segments)
        _GRAPHS[key] = g
        while len(_GRAPHS) > _CACHE_SIZE:
            _GRAPHS.popitem(last=False)
    else:
        _GRAPHS.move_to_end(key)
    return g
