"""The shield's goal search: of every first action followed by every continuation, the manoeuvre
that passes through the goal soonest and keeps the margin from the returns up to it.

Why a table built once: the manoeuvres (21 first actions x 265 continuations of 14 decisions, 28
points each: 156,000 points) do not depend on the scan, so their points in the vehicle frame are
laid out once per process and look-ahead. Many manoeuvres fly the same way for a while (hold a turn
for 6 or for 9 decisions: the same first 6), so the table keeps each shared point once, as a node
(first action, slot, actions up to it): 79,000 nodes. A search then asks two things:

- Which nodes come within ``goal_pass`` of the goal, as the drift carries the vehicle? At slot p
  every manoeuvre is flown at the same time ``t_p``, so the test is "within ``goal_pass`` of
  ``goal - t_p * drift``": the table holds each slot's nodes sorted by x, and a binary search
  finds the few in the goal's x-window (session 43 tested all 156,000 points: 2.7 ms per search).
- Which of those ways keep ``min_clearance`` up to the goal, soonest first? Each hit node is one
  way there, measured once against the returns (session 43 measured every manoeuvre through it:
  500 blocked manoeuvres took 5-10 ms); a node whose way met the goal earlier is dropped, since
  the earlier node is measured first and keeps at least as much clearance.

A search takes 0.45 ms p50, 2.0 ms p99 in the decision loop (375 searches of sea cells 19 and 23;
session 43's: 2.7 and 7.3 ms). Pure NumPy; the answers are those of testing every point of every
manoeuvre (``tests/sim/test_goal_search.py``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .controller import nearest_distance

CHECKS = 32   # manoeuvres measured against the returns at once (soonest first; most searches stop in the first)


@dataclass(frozen=True)
class GoalSearch:
    """The manoeuvres' points, laid out for the goal test (built by ``build``).

    A node is a point of one or more manoeuvres that fly the same way up to it: (first action f,
    point slot p, the continuation's actions up to p); node ids run slot by slot. ``first``:
    [F, 2, 2] the first decision's mid and end point per first action; ``points``: [F, C, P, 2]
    each continuation's points after each first action, vehicle frame; ``node``: [F, C, P] the node
    of each manoeuvre's point; ``node_f``, ``node_c``, ``node_slot``: each node's first action, one
    continuation through it (the lowest) and slot; ``key``, ``sorted_node``, ``xy``: the nodes
    ordered by (slot, x), as the sort key ``slot * span + x``, the node and its point."""

    first: np.ndarray
    points: np.ndarray
    node: np.ndarray
    node_f: np.ndarray
    node_c: np.ndarray
    node_slot: np.ndarray
    key: np.ndarray
    sorted_node: np.ndarray
    xy: np.ndarray
    span: float

    @classmethod
    def build(cls, ends: np.ndarray, conts: np.ndarray, actions: np.ndarray) -> "GoalSearch":
        """``ends`` [F, 3]: the pose after each first action; ``conts`` [C, P, 2]: the continuations
        from the origin; ``actions`` [C, P // 2]: the action each continuation holds per decision."""
        c, s = np.cos(ends[:, 2]), np.sin(ends[:, 2])
        rot = np.stack([np.stack([c, s], axis=-1), np.stack([-s, c], axis=-1)], axis=1)     # [F, 2, 2]
        n_f, (n_c, n_p) = len(ends), conts.shape[:2]
        points = np.empty((n_f, n_c, n_p, 2))           # [F, C, P, 2], filled per first action: no 5 MB temporaries
        for f in range(n_f):
            points[f] = np.einsum("cpk,kl->cpl", conts, rot[f]) + ends[f, :2]
        first = np.stack([0.5 * ends[:, :2], ends[:, :2]], axis=1)
        span = 2.0 * max(float(np.abs(points[f, ..., 0]).max()) for f in range(n_f)) + 10.0
        ways = [np.unique(actions[:, :p // 2 + 1], axis=0, return_index=True, return_inverse=True)[1:]
                for p in range(n_p)]                      # slot p belongs to decision p // 2
        total = n_f * sum(len(rep) for rep, _ in ways)
        node = np.empty((n_f, n_c, n_p), dtype=np.int32)     # ids < 2**31: 80,000 nodes
        node_f, node_c, node_slot, sorted_node = (np.empty(total, dtype=np.int32) for _ in range(4))
        key, xy = np.empty(total), np.empty((total, 2))      # filled slot by slot: no lists to join
        count = 0
        for p, (rep, way) in enumerate(ways):
            at = points[:, rep, p].reshape(-1, 2)             # node count + i is at[i]
            here = slice(count, count + len(at))
            node[:, :, p] = count + np.arange(n_f)[:, None] * len(rep) + way.reshape(-1)[None, :]
            node_f[here], node_c[here], node_slot[here] = np.repeat(np.arange(n_f), len(rep)), np.tile(rep, n_f), p
            order = np.argsort(at[:, 0], kind="stable")
            key[here], sorted_node[here], xy[here] = p * span + at[order, 0], count + order, at[order]
            count += len(at)
        return cls(first, points, node, node_f, node_c, node_slot, key, sorted_node, xy, span)

    def hits(self, goal: np.ndarray, drift: np.ndarray, t_cont: np.ndarray, goal_pass: float) -> np.ndarray:
        """The nodes within ``goal_pass`` of the goal carried by ``drift`` (slot by slot): only the
        nodes in the goal's x-window at each slot are tested."""
        n_p = self.points.shape[2]
        target = goal - t_cont[:, None] * drift                                          # [P, 2]
        base = np.arange(n_p) * self.span + target[:, 0]
        pad = goal_pass + 1e-6                            # the key's rounding: never narrower than the test
        lo, hi = np.searchsorted(self.key, base - pad), np.searchsorted(self.key, base + pad, side="right")
        lens = hi - lo
        slot = np.repeat(np.arange(n_p), lens)
        idx = np.arange(int(lens.sum())) - np.repeat(np.cumsum(lens) - lens, lens) + np.repeat(lo, lens)
        d = self.xy[idx] - target[slot]
        return self.sorted_node[idx[(d * d).sum(axis=1) < goal_pass * goal_pass]]

    def find(self, rank: np.ndarray, goal: np.ndarray, drift: np.ndarray, t_first: np.ndarray,
             t_cont: np.ndarray, returns: np.ndarray, relative: np.ndarray, goal_pass: float,
             min_clearance: float) -> int | None:
        """The first action (index) of the manoeuvre that passes through ``goal`` soonest and keeps
        ``min_clearance`` from the returns up to it, or None; ties: the lowest ``rank`` [F] of the
        first action (the policy's nearest first). ``goal``, ``drift``: vehicle frame; ``t_first``
        [2], ``t_cont`` [P]: the points' times.

        Each manoeuvre is measured up to where it first meets the goal: a hit node whose way there
        met the goal earlier is dropped (that earlier node comes first in the order, and its shorter
        way keeps at least the clearance of the longer one, so the longer way could only win where
        the earlier one already has), and so is every node after a first decision that meets it."""
        at_first = ((self.first + t_first[:, None] * drift - goal) ** 2).sum(axis=-1) < goal_pass ** 2   # [F, 2]
        hit_first = at_first.any(axis=1)
        nodes = self.hits(goal, drift, t_cont, goal_pass)
        f, c, slot = self.node_f[nodes], self.node_c[nodes], self.node_slot[nodes]
        met = np.zeros(len(self.node_f), dtype=bool)
        met[nodes] = True
        earlier = (met[self.node[f, c]] & (np.arange(self.points.shape[2]) < slot[:, None])).any(axis=1)
        keep = ~earlier & ~hit_first[f]
        early = np.flatnonzero(hit_first)
        f = np.concatenate([early, f[keep]])
        c = np.concatenate([np.zeros(len(early), dtype=np.int64), c[keep]])
        when = np.concatenate([at_first[early].argmax(axis=1), slot[keep] + 2])   # 0, 1: the first decision's
        order = np.lexsort((c, rank[f], when))            # soonest, then nearest the policy's action
        f, c, when = f[order], c[order], when[order]
        times = np.concatenate([t_first, t_cont])
        for lo in range(0, len(f), CHECKS):
            fs, cs, ws = f[lo:lo + CHECKS], c[lo:lo + CHECKS], when[lo:lo + CHECKS]
            cols = int(ws.max()) + 1
            pts = np.concatenate([self.first[fs], self.points[fs, cs, :max(cols - 2, 0)]], axis=1)[:, :cols]
            d = nearest_distance(pts, times[None, :cols], relative, returns)
            d = np.where(np.arange(cols)[None, :] > ws[:, None], np.inf, d).min(axis=1)
            ok = np.flatnonzero(d >= min_clearance)
            if len(ok):
                return int(fs[ok[0]])
        return None
