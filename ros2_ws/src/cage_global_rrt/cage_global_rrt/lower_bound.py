"""A lower bound on the shortest collision-free path: a visibility graph over polygons inscribed in
the inflated obstacles.

Why it is a lower bound: every inflated obstacle (a square grown by ``margin`` with rounded
corners, or a grown circle) is replaced by a convex polygon whose vertices lie on its boundary, so
the polygon sits inside the obstacle. Any path that keeps the clearance also avoids the polygons,
and the shortest path among convex polygons is a visibility-graph path, so the graph's shortest
path is never longer than the true one. The net (a convex disc of radius R - margin) only drops
vertices outside it; chords between points inside a disc stay inside. Used by the benchmark (path
length relative to the shortest path) and by the planner to tell NO_VALID_PATH from TIMEOUT.
"""
from __future__ import annotations

import heapq
import math

import numpy as np

from .geometry import _jit
from .known_map import KnownMap

ARC_POINTS = 3  # points per rounded corner (0, 45, 90 degrees): 12-gon per square
CIRCLE_POINTS = 12


def inscribed_polygons(kmap: KnownMap, margin: float) -> np.ndarray:
    """(P, 12, 2) convex CCW polygons inside each inflated obstacle."""
    polys = []
    for cx, cy, h in kmap.squares:
        pts = []
        for k, (sx, sy) in enumerate(((1, -1), (1, 1), (-1, 1), (-1, -1))):
            base = -0.5 * math.pi + k * 0.5 * math.pi  # arc of corner k runs over a quarter turn
            for j in range(ARC_POINTS):
                a = base + j * 0.5 * math.pi / (ARC_POINTS - 1)
                pts.append((cx + sx * h + margin * math.cos(a), cy + sy * h + margin * math.sin(a)))
        polys.append(pts)
    for cx, cy, r in kmap.circles:
        rr = r + margin
        polys.append([(cx + rr * math.cos(a), cy + rr * math.sin(a))
                      for a in np.linspace(0.0, 2.0 * math.pi, CIRCLE_POINTS, endpoint=False)])
    return np.asarray(polys, dtype=np.float64).reshape(-1, 12, 2)


@_jit
def _blocks(ax, ay, bx, by, poly, eps):
    """Segment a-b passes through the interior of convex polygon ``poly`` (separating axes;
    touching the boundary is allowed)."""
    K = poly.shape[0]
    lox = min(ax, bx)
    hix = max(ax, bx)
    loy = min(ay, by)
    hiy = max(ay, by)
    if poly[:, 0].max() <= lox + eps or poly[:, 0].min() >= hix - eps or \
            poly[:, 1].max() <= loy + eps or poly[:, 1].min() >= hiy - eps:
        return False
    for i in range(K + 1):
        if i < K:
            ex = poly[(i + 1) % K, 0] - poly[i, 0]
            ey = poly[(i + 1) % K, 1] - poly[i, 1]
        else:
            ex = bx - ax
            ey = by - ay
        L = math.sqrt(ex * ex + ey * ey)
        if L < 1e-12:
            continue
        nx = ey / L
        ny = -ex / L
        pmin = 1e300
        pmax = -1e300
        for k in range(K):
            p = poly[k, 0] * nx + poly[k, 1] * ny
            pmin = min(pmin, p)
            pmax = max(pmax, p)
        sa = ax * nx + ay * ny
        sb = bx * nx + by * ny
        if max(sa, sb) <= pmin + eps or min(sa, sb) >= pmax - eps:
            return False
    return True


@_jit
def _visible(ax, ay, bx, by, polys, skip_a, skip_b, eps):
    for p in range(polys.shape[0]):
        if p == skip_a and p == skip_b:
            continue  # same polygon: caller handles (only its own edges are visible)
        if _blocks(ax, ay, bx, by, polys[p], eps):
            return False
    return True


@_jit
def _vertex_graph(verts, owner, index, inside, polys, eps):
    """Dense edge-length matrix between polygon vertices (inf = not visible)."""
    n = verts.shape[0]
    W = np.full((n, n), np.inf)
    K = polys.shape[1]
    for i in range(n):
        if not inside[i]:
            continue
        for j in range(i + 1, n):
            if not inside[j]:
                continue
            if owner[i] == owner[j]:
                d = abs(index[i] - index[j])
                if d != 1 and d != K - 1:
                    continue  # a chord of a convex polygon crosses its interior
            if _visible(verts[i, 0], verts[i, 1], verts[j, 0], verts[j, 1], polys, owner[i], owner[j], eps):
                w = math.hypot(verts[i, 0] - verts[j, 0], verts[i, 1] - verts[j, 1])
                W[i, j] = w
                W[j, i] = w
    return W


@_jit
def _point_edges(px, py, verts, inside, polys, eps):
    n = verts.shape[0]
    out = np.full(n, np.inf)
    for i in range(n):
        if inside[i] and _visible(px, py, verts[i, 0], verts[i, 1], polys, -1, -2, eps):
            out[i] = math.hypot(px - verts[i, 0], py - verts[i, 1])
    return out


class VisibilityGraph:
    """Built once per (map, margin); ``shortest(start, goal)`` per query."""

    def __init__(self, kmap: KnownMap, margin: float, eps: float = 1e-9) -> None:
        self.kmap, self.margin, self.eps = kmap, margin, eps
        self.polys = inscribed_polygons(kmap, margin)
        P = self.polys.shape[0]
        self.verts = self.polys.reshape(-1, 2).copy()
        self.owner = np.repeat(np.arange(P), 12)
        self.index = np.tile(np.arange(12), P)
        r = kmap.net_radius - margin
        self.inside = np.hypot(self.verts[:, 0], self.verts[:, 1]) <= r
        self.W = _vertex_graph(self.verts, self.owner, self.index, self.inside, self.polys, eps)

    def shortest(self, start, goal) -> float:
        """Length of the shortest graph path (inf when the graph has none)."""
        return self.shortest_path(start, goal)[0]

    def shortest_path(self, start, goal) -> tuple[float, np.ndarray]:
        sx, sy = float(start[0]), float(start[1])
        gx, gy = float(goal[0]), float(goal[1])
        if _visible(sx, sy, gx, gy, self.polys, -1, -2, self.eps):
            return math.hypot(gx - sx, gy - sy), np.array([[sx, sy], [gx, gy]])
        ws = _point_edges(sx, sy, self.verts, self.inside, self.polys, self.eps)
        wg = _point_edges(gx, gy, self.verts, self.inside, self.polys, self.eps)
        return self._dijkstra(ws, wg, (sx, sy), (gx, gy))

    def _dijkstra(self, ws, wg, s, g):
        n = len(ws)
        dist = np.full(n, np.inf)
        prev = np.full(n, -1)
        heap = []
        for i in np.flatnonzero(np.isfinite(ws)):
            dist[i] = ws[i]
            heap.append((ws[i], int(i)))
        heapq.heapify(heap)
        best, last = math.inf, -1
        W = self.W
        while heap:
            d, i = heapq.heappop(heap)
            if d > dist[i] or d >= best:
                continue
            if d + wg[i] < best:
                best, last = d + wg[i], i
            row = W[i]
            for j in np.flatnonzero(row < np.inf):
                nd = d + row[j]
                if nd < dist[j]:
                    dist[j], prev[j] = nd, i
                    heapq.heappush(heap, (nd, int(j)))
        if last < 0:
            return math.inf, np.zeros((0, 2))
        chain = []
        while last >= 0:
            chain.append(self.verts[last])
            last = prev[last]
        return best, np.vstack([s, *chain[::-1], g])


def shortest_path_lower_bound(kmap: KnownMap, start, goal, margin: float) -> float:
    """One-shot lower bound (builds the graph; keep a VisibilityGraph for many queries)."""
    return VisibilityGraph(kmap, margin).shortest(start, goal)
