"""Transit inside the area: the shortest path that never leaves it (visibility graph).

A straight transit between two swaths can cross a hole or cut across a concavity. When it would,
the path bends at the area's reflex corners and the holes' corners — the shortest path inside a
polygon only ever bends there — found by A* over the corners that see each other.

A 2000-vertex outline has about a thousand such corners, and a visibility graph over all of them
is half a million segment tests: minutes. The search here never builds it. A* (the straight
distance to the goal is the heuristic) expands a corner's neighbours lazily, nearest-first by
``|u v| + |v b|`` in batches that double in size, and tests a batch's segments in one
vectorised call; what it learns about two corners seeing each other is kept for later transits.
A transit between neighbouring swaths then tests a few dozen segments, not the whole graph,
and the path is still the shortest one (the batches come out in the order A* would take them).
"""

from __future__ import annotations

import heapq
import math

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon
from shapely.geometry.polygon import orient

XY = tuple[float, float]


def reflex_corners(area: Polygon) -> list[XY]:
    area = orient(area, sign=1.0)  # exterior counter-clockwise, holes clockwise
    corners: list[XY] = []
    for ring, is_hole in [(area.exterior, False)] + [(r, True) for r in area.interiors]:
        pts = list(ring.coords)[:-1]
        for i, (x, y) in enumerate(pts):
            if is_hole:
                corners.append((x, y))  # every hole corner can be a bend
                continue
            (ax, ay), (bx, by) = pts[i - 1], pts[(i + 1) % len(pts)]
            if (x - ax) * (by - y) - (y - ay) * (bx - x) < 0:  # right turn: reflex
                corners.append((x, y))
    return corners


_reflex_corners = reflex_corners  # the name tests/unit/planner/test_planner_bounds.py imports


class InAreaRouter:
    """Shortest paths between points of ``area`` that stay inside it (within ``eps_m``)."""

    first_batch = 16

    def __init__(self, area: Polygon, eps_m: float = 1e-6) -> None:
        self.area = area
        self._cover = area.buffer(eps_m)
        shapely.prepare(self._cover)
        self._nodes: np.ndarray | None = None
        self._seen: np.ndarray = np.zeros((0, 0), dtype=np.int8)  # 1 sees, 0 not, -1 unknown

    def visible(self, a: XY, b: XY) -> bool:
        if a == b:
            return bool(self._cover.covers(shapely.points(a)))
        return bool(self._cover.covers(LineString([a, b])))

    def _corners(self) -> np.ndarray:
        if self._nodes is None:
            self._nodes = np.asarray(reflex_corners(self.area), dtype=float).reshape(-1, 2)
            m = len(self._nodes)
            self._seen = np.full((m, m), -1, dtype=np.int8)
        return self._nodes

    def _sees(self, pts: np.ndarray, u: int, vs: np.ndarray) -> np.ndarray:
        """Whether ``pts[u]`` sees each of ``pts[vs]`` (corner pairs are remembered)."""
        m = len(self._seen)
        known = np.full(len(vs), -1, dtype=np.int8)
        corner = vs < m
        if u < m:
            known[corner] = self._seen[u, vs[corner]]
        ask = known < 0
        if ask.any():
            ends = vs[ask]
            segs = np.empty((len(ends), 2, 2))
            segs[:, 0] = pts[u]
            segs[:, 1] = pts[ends]
            known[ask] = shapely.covers(self._cover, shapely.linestrings(segs))
            if u < m:
                both = vs[ask] < m
                self._seen[u, vs[ask][both]] = known[ask][both]
                self._seen[vs[ask][both], u] = known[ask][both]
        return known.astype(bool)

    def path(self, a: XY, b: XY) -> list[XY]:
        """``[a, corners..., b]``; just ``[a, b]`` when the straight line stays inside."""
        if self.visible(a, b):
            return [a, b]
        nodes = self._corners()
        m = len(nodes)
        pts = np.vstack([nodes, [a], [b]])
        src, dst = m, m + 1
        to_b = np.hypot(*(pts - pts[dst]).T)
        g = np.full(m + 2, math.inf)
        g[src] = 0.0
        prev = np.full(m + 2, -1)
        order: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        # (f, tie, kind, node, next batch start): kind 0 arrives at node, kind 1 offers the
        # node's next batch of neighbours (its f is the best f left in the batch).
        heap: list[tuple[float, int, int, int, int]] = [(to_b[src], 0, 0, src, 0)]
        tie = 1
        while heap:
            f, _, kind, u, k = heapq.heappop(heap)
            if kind == 0:
                if f > g[u] + to_b[u] + 1e-12:
                    continue  # a stale arrival
                if u == dst:
                    break
                keys = np.hypot(pts[:, 0] - pts[u, 0], pts[:, 1] - pts[u, 1]) + to_b
                keys[u] = keys[src] = math.inf  # neither is a neighbour to offer
                rank = np.argsort(keys, kind="stable")[: m + 1 if u == src else m]
                order[u] = (rank, keys[rank])
                heapq.heappush(heap, (g[u] + float(keys[rank[0]]), tie, 1, u, 0))
                tie += 1
                continue
            cand, keys = order[u]
            size = max(self.first_batch, k)  # batches double: 16, 16, 32, 64, ...
            batch = cand[k : k + size]
            seen = batch[self._sees(pts, u, batch)]
            # Relax the visible ones at once; push only those it improves (in batch order).
            d = g[u] + np.hypot(*(pts[seen] - pts[u]).T)
            better = d < g[seen] - 1e-12
            for v, dv in zip(seen[better].tolist(), d[better].tolist(), strict=True):
                g[v], prev[v] = dv, u
                heapq.heappush(heap, (dv + float(to_b[v]), tie, 0, v, 0))
                tie += 1
            if k + size < len(cand):
                heapq.heappush(heap, (g[u] + float(keys[k + size]), tie, 1, u, k + size))
                tie += 1
        if not math.isfinite(g[dst]):
            raise ValueError(f"no path inside the area from {a} to {b}")
        out = [b]
        i = dst
        while i != src:
            i = int(prev[i])
            out.append(a if i == src else (float(pts[i][0]), float(pts[i][1])))
        return out[::-1]
