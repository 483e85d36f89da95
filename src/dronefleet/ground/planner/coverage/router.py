"""Transit inside the area: the shortest path that never leaves it (visibility graph).

A straight transit between two swaths can cross a hole or cut across a concavity. When it would,
the path bends at the area's reflex corners and the holes' corners — the shortest path inside a
polygon only ever bends there — found by Dijkstra over the corners that see each other.
"""

from __future__ import annotations

import heapq
import math

import shapely
from shapely.geometry import LineString, Polygon
from shapely.geometry.polygon import orient

XY = tuple[float, float]


def _reflex_corners(area: Polygon) -> list[XY]:
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


class InAreaRouter:
    """Shortest paths between points of ``area`` that stay inside it (within ``eps_m``)."""

    def __init__(self, area: Polygon, eps_m: float = 1e-6) -> None:
        self.area = area
        self._cover = area.buffer(eps_m)
        shapely.prepare(self._cover)
        self._nodes: list[XY] | None = None
        self._adjacency: list[list[tuple[int, float]]] = []

    def visible(self, a: XY, b: XY) -> bool:
        if a == b:
            return bool(self._cover.covers(shapely.points(a)))
        return bool(self._cover.covers(LineString([a, b])))

    def path(self, a: XY, b: XY) -> list[XY]:
        """``[a, corners..., b]``; just ``[a, b]`` when the straight line stays inside."""
        if self.visible(a, b):
            return [a, b]
        nodes = self._graph()
        n = len(nodes)
        # Dijkstra from a (index n) to b (index n + 1) over the corners.
        dist = {n: 0.0}
        prev: dict[int, int] = {}
        heap = [(0.0, n)]
        sees_b = [self.visible(c, b) for c in nodes]
        while heap:
            d, i = heapq.heappop(heap)
            if i == n + 1:
                break
            if d > dist.get(i, math.inf):
                continue
            here = a if i == n else nodes[i]
            if i == n:
                edges = [(j, math.dist(a, c)) for j, c in enumerate(nodes) if self.visible(a, c)]
            else:
                edges = list(self._adjacency[i])
                if sees_b[i]:
                    edges.append((n + 1, math.dist(here, b)))
            for j, w in edges:
                if d + w < dist.get(j, math.inf):
                    dist[j], prev[j] = d + w, i
                    heapq.heappush(heap, (d + w, j))
        if n + 1 not in dist:
            raise ValueError(f"no path inside the area from {a} to {b}")
        out = [b]
        i = n + 1
        while i != n:
            i = prev[i]
            out.append(a if i == n else nodes[i])
        return out[::-1]

    def _graph(self) -> list[XY]:
        if self._nodes is None:
            nodes = _reflex_corners(self.area)
            self._adjacency = [[] for _ in nodes]
            for i, p in enumerate(nodes):
                for j in range(i + 1, len(nodes)):
                    if self.visible(p, nodes[j]):
                        w = math.dist(p, nodes[j])
                        self._adjacency[i].append((j, w))
                        self._adjacency[j].append((i, w))
            self._nodes = nodes
        return self._nodes
