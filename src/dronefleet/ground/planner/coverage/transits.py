"""The cost of every transit between swath ends, inside the area (stage 4's input).

The route solver (:mod:`.solver`) compares thousands of transits, so their costs are computed
once, as a matrix, instead of asking :class:`~.router.InAreaRouter` (A*) for each. The shortest
path inside a polygon bends only at its reflex corners and at the corners of its holes, so:

* a transit whose straight segment stays inside is that segment;
* any other goes ``a -> c1 -> ... -> c2 -> b`` over corners: ``a`` sees ``c1``, ``b`` sees
  ``c2``, and between them the cheapest way over corners that see each other (Floyd-Warshall
  on the corners, a few dozen of them in a field).

Visibility is decided in numpy for a whole batch of segments against every edge: a segment that
properly crosses an edge is blocked; one that neither crosses nor touches a corner lies in one
face, which its midpoint tells; only the rare one through a corner is asked of GEOS. The cost of
a transit is its length plus :data:`BEND_M` per bend: a bend is a waypoint the drone slows down
for (docs/DESIGN.md §6, the estimator's 2 m tolerance) but, reached within 2 m, does not stop
at: about a quarter of a stop-and-go (v²/4a = 10 m at the quad's 10 m/s and 2.5 m/s²). Of 5,
10 and 20 m, 10 gave the shortest paths over the bench's fields (bench/coverage_vs_f2c.py).

Outlines with many corners (a traced 2000-vertex gear) would make the matrices large; the
pipeline does not build a table for them (:func:`affordable`) and keeps the greedy cell route.
"""

from __future__ import annotations

import math

import numpy as np
import shapely
from shapely.geometry import Polygon

from dronefleet.ground.planner.coverage.clip import edges_of
from dronefleet.ground.planner.coverage.router import InAreaRouter, reflex_corners

XY = tuple[float, float]

#: What a bend in a transit costs, in metres of straight flight (see the module docstring).
BEND_M = 10.0
#: Points closer than this (m) to a segment touch it; the router's tolerance.
EPS_M = 1e-6
#: Most corners and edges a table is built with, and most segment-edge tests in one batch.
MAX_CORNERS = 64
MAX_EDGES = 400
BATCH = 250_000
#: Largest (ends² x edges) a table is built for: about 0.1 s of numpy on this machine's cores.
MAX_WORK = 6_000_000
#: Every pair costed at once up to this many (ends² x blocking edges); past that each end's
#: NEAR nearest others at first, the rest when a route uses them.
ALL_PAIRS_WORK = 100_000
NEAR = 8


def affordable(area: Polygon, ends: int) -> bool:
    """Whether a table over ``ends`` swath ends of ``area`` is cheap enough to build (a traced
    outline of thousands of vertices is not: its edges alone cost more than the route saves)."""
    edges = len(area.exterior.coords) - 1 + sum(len(r.coords) - 1 for r in area.interiors)
    if edges > MAX_EDGES:
        return False
    corners = len(reflex_corners(area))
    return corners <= MAX_CORNERS and ends * ends // 2 * edges <= MAX_WORK


def obstacles(area: Polygon) -> list[tuple[np.ndarray, np.ndarray]]:
    """What a segment between two points of ``area`` can cross: each pocket (a run of exterior
    edges off the convex hull: the notch of an L) and each hole, as (box, edges). Exterior
    edges on the hull cannot be crossed: the whole area lies on one side of their line. Boxes
    are (xmin, ymin, xmax, ymax), edges rows (x0, y0, x1, y1)."""
    edges = edges_of(area)
    ring = np.asarray(area.exterior.coords)[:-1, :2]
    outer = edges[: len(ring)]
    d = outer[:, 2:] - outer[:, :2]
    rel = ring[None, :, :] - outer[:, None, :2]
    side = d[:, None, 0] * rel[..., 1] - d[:, None, 1] * rel[..., 0]
    scale = np.hypot(d[:, 0], d[:, 1])[:, None]
    on_hull = np.all(side >= -EPS_M * scale, axis=1) | np.all(side <= EPS_M * scale, axis=1)
    groups: list[np.ndarray] = []
    if not on_hull.all():  # pockets: runs of edges off the hull, from a hull edge on
        start = int(np.argmax(on_hull))
        run: list[np.ndarray] = []
        for k in range(start, start + len(outer) + 1):
            if not on_hull[k % len(outer)]:
                run.append(outer[k % len(outer)])
            elif run:
                groups.append(np.vstack(run))
                run = []
        if run:  # no edge on the hull at all (a star): one pocket all round
            groups.append(np.vstack(run))
    at = len(ring)
    for hole in area.interiors:
        count = len(hole.coords) - 1
        groups.append(edges[at : at + count])
        at += count
    out = []
    for group in groups:
        pts = group.reshape(-1, 2)
        out.append((np.array([*pts.min(axis=0), *pts.max(axis=0)]), group))
    return out


class Visibility:
    """Which segments stay inside ``area`` (its boundary counts as inside)."""

    def __init__(self, area: Polygon) -> None:
        self.groups = obstacles(area)
        self.edges = np.vstack([g for _, g in self.groups]) if self.groups else np.zeros((0, 4))
        self.cover = area.buffer(EPS_M)
        shapely.prepare(self.cover)

    def of(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """For segments ``a[i] -> b[i]`` ((p, 2) arrays): whether each stays inside.

        A segment is tested only against the obstacles whose box it touches: only they can
        block it (a segment off every box lies inside the hull and crosses no pocket or hole)."""
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        near = np.zeros(len(a), dtype=bool)
        blocked = np.zeros(len(a), dtype=bool)
        touch = np.zeros(len(a), dtype=bool)
        for box, edges in self.groups:
            x0, y0, x1, y1 = (box + np.array([-EPS_M, -EPS_M, EPS_M, EPS_M])).tolist()
            hit = np.flatnonzero(
                (lo[:, 0] <= x1) & (hi[:, 0] >= x0) & (lo[:, 1] <= y1) & (hi[:, 1] >= y0)
            )
            near[hit] = True
            step = max(1, BATCH // len(edges))
            for k in range(0, len(hit), step):
                part = hit[k : k + step]
                crossed, touched = _crossings(a[part], b[part], edges)
                blocked[part] |= crossed
                touch[part] |= touched
        out = ~blocked
        ask = np.flatnonzero(near & ~blocked)
        mid = (a[ask] + b[ask]) / 2.0
        out[ask] = shapely.contains_xy(self.cover, mid[:, 0], mid[:, 1])
        unsure = np.flatnonzero(near & ~blocked & touch)  # through a corner: GEOS decides
        if len(unsure):
            segs = np.stack([a[unsure], b[unsure]], axis=1)
            out[unsure] = shapely.covers(self.cover, shapely.linestrings(segs))
        return out


def _crossings(a: np.ndarray, b: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For segments a -> b against edges ``e``: whether each properly crosses one, and whether
    a corner (an edge's start) lies on it away from its ends."""
    ax, ay, bx, by = a[:, :1], a[:, 1:], b[:, :1], b[:, 1:]
    ex, ey = e[None, :, 0], e[None, :, 1]
    dx, dy = e[None, :, 2] - ex, e[None, :, 3] - ey
    inv = 1.0 / np.maximum(np.hypot(dx, dy), 1e-12)
    # Signed distances of a and b from each edge's line...
    sa = (dx * (ay - ey) - dy * (ax - ex)) * inv
    sb = (dx * (by - ey) - dy * (bx - ex)) * inv
    crosses = (sa * sb < 0) & (np.abs(sa) > EPS_M) & (np.abs(sb) > EPS_M)
    # ... and of each edge's ends from ab's line.
    ux, uy = bx - ax, by - ay
    inv_ab = 1.0 / np.maximum(np.hypot(ux, uy), 1e-12)
    s0 = (ux * (ey - ay) - uy * (ex - ax)) * inv_ab
    s1 = s0 + (ux * dy - uy * dx) * inv_ab
    crosses &= (s0 * s1 < 0) & (np.abs(s0) > EPS_M) & (np.abs(s1) > EPS_M)
    p, k = np.nonzero(np.abs(s0) <= EPS_M)
    t = ((ex[0, k] - ax[p, 0]) * ux[p, 0] + (ey[0, k] - ay[p, 0]) * uy[p, 0]) * inv_ab[p, 0]
    on = (t > EPS_M) & (t < 1.0 / inv_ab[p, 0] - EPS_M)
    touched = np.zeros(len(a), dtype=bool)
    touched[p[on]] = True
    return crosses.any(axis=1), touched


class TransitTable:
    """Transit costs (metres + bends) between ``points`` and the paths behind them.

    ``cost[i, j]`` is symmetric. It is exact where ``exact[i, j]``; elsewhere it is the straight
    distance, a lower bound. A field of 128 swaths has 32,000 pairs of ends and a route uses 127
    of them, so only each end's nearest others are costed at first (:data:`NEAR`), and the
    route's other transits when a solution uses them (:meth:`verify`; the solver is run again
    until every transit it uses is exact, :class:`~.route.WholeFieldOrderer`).
    """

    sight: Visibility
    corners: np.ndarray  # reflex corners and the holes' corners
    _dist: np.ndarray  # corner to corner, over corners (Floyd-Warshall)
    _nxt: np.ndarray  # the next corner on that way
    _reach: np.ndarray  # point to corner it sees (+ half a bend)
    _via: np.ndarray  # point to corner, over corners

    def __init__(
        self,
        area: Polygon,
        points: np.ndarray,
        bend_m: float = BEND_M,
        like: TransitTable | None = None,
    ) -> None:
        """``like``: a table of the same area and bend cost, whose corners are reused."""
        self.area, self.points, self.bend_m = area, np.asarray(points, dtype=float), bend_m
        n = len(self.points)
        d = self.points[:, None, :] - self.points[None, :, :]
        self.cost = np.hypot(d[..., 0], d[..., 1])
        self.exact = np.eye(n, dtype=bool)
        self.seen = np.eye(n, dtype=bool)
        known: np.ndarray | None = None
        if like is not None and like.area is area and like.bend_m == bend_m:
            self.sight, self.corners = like.sight, like.corners
            if len(self.corners):
                self._dist, self._nxt = like._dist, like._nxt
            # Points ``like`` has costed already: their pairs are copied, not tested again.
            index = {(x, y): k for k, (x, y) in enumerate(like.points.tolist())}
            known = np.array([index.get((x, y), -1) for x, y in self.points.tolist()])
        else:
            self.sight = Visibility(area)
            self.corners = np.asarray(reflex_corners(area), dtype=float).reshape(-1, 2)
            if len(self.corners):
                self._corner_graph(len(self.corners))
        m = len(self.corners)
        if m:
            # End to corner: |x c| + half a bend where x sees c; then via[a, c2] = the cheapest
            # way from a to corner c2 over corners.
            reach = np.full((n, m), np.inf)
            fresh = np.arange(n) if known is None or like is None else np.flatnonzero(known < 0)
            if known is not None and like is not None:
                reach[known >= 0] = like._reach[known[known >= 0]] - bend_m / 2.0
            pi, ci = np.divmod(np.arange(len(fresh) * m), m)
            pi = fresh[pi]
            ok = self.sight.of(self.points[pi], self.corners[ci])
            reach[pi[ok], ci[ok]] = np.hypot(*(self.points[pi[ok]] - self.corners[ci[ok]]).T)
            self._reach = reach + bend_m / 2.0
            self._via = (self._reach[:, :, None] + self._dist[None, :, :]).min(axis=1)
        if known is not None and like is not None and (known >= 0).any():
            mine = np.flatnonzero(known >= 0)
            theirs = known[mine]
            block = np.ix_(mine, mine)
            self.cost[block] = like.cost[np.ix_(theirs, theirs)]
            self.exact[block] = like.exact[np.ix_(theirs, theirs)]
            self.seen[block] = like.seen[np.ix_(theirs, theirs)]
        near = min(NEAR, n - 1)
        if n * n * max(1, len(self.sight.edges)) <= ALL_PAIRS_WORK:
            iu, ju = np.triu_indices(n, 1)
            self.verify(iu, ju)
        elif near > 0:
            closest = np.argsort(self.cost, axis=1, kind="stable")[:, 1 : near + 1]
            self.verify(np.repeat(np.arange(n), near), closest.ravel())

    def verify(self, i: np.ndarray, j: np.ndarray) -> None:
        """Make ``cost[i, j]`` exact for these pairs (both ways)."""
        i, j = np.minimum(i, j), np.maximum(i, j)
        todo = ~self.exact[i, j]
        if not todo.any():
            return
        i, j = i[todo], j[todo]
        if len(i) > 1:  # each pair once: (i, j) as one integer
            _, first = np.unique(i * len(self.points) + j, return_index=True)
            i, j = i[first], j[first]
        seen = self.sight.of(self.points[i], self.points[j])
        cost = self.cost[i, j].copy()
        if len(self.corners) and not seen.all():
            a, b = i[~seen], j[~seen]
            cost[~seen] = (self._via[a] + self._reach[b]).min(axis=1)
        elif not seen.all():
            cost[~seen] = np.inf
        self.cost[i, j] = self.cost[j, i] = cost
        self.seen[i, j] = self.seen[j, i] = seen
        self.exact[i, j] = self.exact[j, i] = True

    def verify_rows(self, ends: np.ndarray) -> None:
        """Make exact every pair that has one of ``ends`` in it."""
        ends = np.unique(ends)
        n = len(self.points)
        i = np.repeat(ends, n)
        j = np.tile(np.arange(n), len(ends))
        keep = i != j
        self.verify(i[keep], j[keep])

    def _corner_graph(self, m: int) -> None:
        ci, cj = np.triu_indices(m, 1)
        ok = self.sight.of(self.corners[ci], self.corners[cj])
        dist = np.full((m, m), np.inf)
        dist[ci[ok], cj[ok]] = np.hypot(*(self.corners[ci[ok]] - self.corners[cj[ok]]).T)
        dist = np.minimum(dist, dist.T) + self.bend_m
        np.fill_diagonal(dist, 0.0)
        nxt = np.tile(np.arange(m), (m, 1))
        for k in range(m):  # Floyd-Warshall, a row of relaxations at a time
            through = dist[:, k, None] + dist[None, k, :]
            better = through < dist - 1e-12
            dist = np.where(better, through, dist)
            nxt = np.where(better, nxt[:, k, None], nxt)
        self._dist, self._nxt = dist, nxt

    def path(self, i: int, j: int) -> list[XY]:
        """The transit from point ``i`` to point ``j``: ``[a, corners..., b]``."""
        a = (float(self.points[i][0]), float(self.points[i][1]))
        b = (float(self.points[j][0]), float(self.points[j][1]))
        if i == j:
            return [a, b]
        if not self.exact[i, j]:
            self.verify(np.array([i]), np.array([j]))
        if self.seen[i, j]:
            return [a, b]
        if not math.isfinite(float(self.cost[i, j])):
            return InAreaRouter(self.area).path(a, b)
        c2 = int(np.argmin(self._via[i] + self._reach[j]))
        c1 = int(np.argmin(self._reach[i] + self._dist[:, c2]))
        hops = [c1]
        while hops[-1] != c2:
            hops.append(int(self._nxt[hops[-1], c2]))
        corners = [(float(self.corners[c][0]), float(self.corners[c][1])) for c in hops]
        return [a, *corners, b]
