"""A contour route: the area's outline flown ring by ring inward, the other pattern of stage 4.

Swaths across a thin, bent field turn at every few metres and leave wedges at the bend: the
bench's 16 m wide dog-leg flies 837 m in swaths, 713 m in rings (bench/coverage_vs_f2c.py,
issue 30). The first ring is half a spacing inside the outline, each next one a spacing further
in (the area eroded, corners mitred so that a ring's bends are few), until nothing is left. The
first ring's corners are moved out towards the outline's (:func:`pointed`); :mod:`.gaps` closes
what is left as it does for swaths. Rings are flown nearest first, each from its corner nearest
the drone, all the way round; transits between them stay inside the area (:mod:`.router`). The
pipeline flies them only where they are clearly quicker than the swaths
(:func:`~.outlines.or_contour`): not on a star, whose tips cost a ring twice
what they cost swaths.

Shapely's negative buffer does the offsetting (GEOS, already the planner's geometry engine):
Fields2Cover's headland rings are the same operation, and a straight-skeleton library would add
a dependency for bends the mitre join already gives.
"""

from __future__ import annotations

import itertools
import math

from shapely.geometry import LineString, MultiPolygon, Polygon
from shapely.geometry.base import BaseGeometry
from shapely.geometry.polygon import orient

from dronefleet.ground.planner.coverage.path import Kind, PathBuilder, RoutePoint
from dronefleet.ground.planner.coverage.route import Flown, Routed, Stroke
from dronefleet.ground.planner.coverage.router import InAreaRouter

XY = tuple[float, float]

#: Ring bends closer than this fraction of the spacing to a straight line are dropped.
SIMPLIFY = 0.05
#: Most rings a contour route is made of (only small fields are offered one).
MOST_RINGS = 40


def rings(area: Polygon, spacing_m: float) -> list[tuple[int, list[XY]]]:
    """The area's rings, outermost first, each with its depth (0: half a spacing inside the
    outline, then a spacing further in each time) and its corners (the first not repeated)."""
    out: list[tuple[int, list[XY]]] = []
    for k in range(MOST_RINGS):
        inner = area.buffer(-(spacing_m / 2.0 + k * spacing_m), join_style="mitre")
        if inner.is_empty:
            break
        parts = inner.geoms if isinstance(inner, MultiPolygon) else [inner]
        for part in parts:
            part = orient(part)  # exterior anticlockwise, holes clockwise (see pointed)
            for ring in (part.exterior, *part.interiors):
                corners = list(ring.simplify(SIMPLIFY * spacing_m).coords)[:-1]
                if corners:
                    out.append((k, [(float(x), float(y)) for x, y in corners]))
    return out


def pointed(ring: list[XY], reach_m: float, cover: BaseGeometry) -> list[XY]:
    """``ring`` (the first, ``reach_m`` = half a spacing inside the outline) with each convex
    corner moved out along its bisector until it is ``reach_m`` from the outline's corner.

    A ring's corner of angle θ is ``reach_m / sin(θ/2)`` from that point, so it leaves the
    point uncovered below 180°: a star's 36° tips by 11.2 m at 10 m spacing, a square's corners
    by 2.1 m. Moved, the corner's two sides pivot about their far ends, which stay half a
    spacing from the outline; in between they are nearer, so the band along the outline stays
    covered (what the sides reached inside moves out with them: the next ring or the gap filler
    covers it). A corner whose new sides would leave the area stays where it is."""
    out = list(ring)
    n = len(ring)
    if n < 3:
        return out
    for k in range(n):
        (px, py), (x, y), (nx, ny) = ring[k - 1], ring[k], ring[(k + 1) % n]
        a, b = (px - x, py - y), (nx - x, ny - y)
        la, lb = math.hypot(*a), math.hypot(*b)
        if la == 0.0 or lb == 0.0:
            continue
        ua, ub = (a[0] / la, a[1] / la), (b[0] / lb, b[1] / lb)
        cross = ua[0] * ub[1] - ua[1] * ub[0]
        half = math.acos(max(-1.0, min(1.0, ua[0] * ub[0] + ua[1] * ub[1]))) / 2.0
        # Rings run anticlockwise round the area (exteriors; holes' rings clockwise round the
        # hole): a convex corner turns left, so the next side is clockwise of the one before.
        if cross >= 0.0 or half <= 0.0:
            continue
        push = reach_m / math.sin(half) - reach_m
        bx, by = ua[0] + ub[0], ua[1] + ub[1]
        norm = math.hypot(bx, by)
        if norm < 1e-9 or push < 1e-3:
            continue
        moved = (x - bx / norm * push, y - by / norm * push)
        if cover.covers(LineString([out[k - 1], moved, out[(k + 1) % n]])):
            out[k] = moved
    return out


def _from_nearest(ring: list[XY], at: XY) -> list[XY]:
    """``ring`` flown all the way round from its corner nearest ``at`` (back to that corner)."""
    k = min(range(len(ring)), key=lambda i: math.dist(ring[i], at))
    turned = ring[k:] + ring[:k]
    return [*turned, turned[0]] if len(turned) > 1 else turned


def contour_route(area: Polygon, spacing_m: float, start: XY) -> Routed | None:
    """The rings as passes (strokes along each ring's sides), nearest ring first from ``start``;
    None when no ring fits."""
    cover = area.buffer(1e-6)
    left = [pointed(r, spacing_m / 2.0, cover) if k == 0 else r for k, r in rings(area, spacing_m)]
    if not left:
        return None
    passes: list[Flown] = []
    at = start
    while left:
        nearest = min(range(len(left)), key=lambda i: min(math.dist(p, at) for p in left[i]))
        ring = _from_nearest(left.pop(nearest), at)
        if len(ring) == 1:
            passes.append(Stroke(ring[0], ring[0]))
        passes += [Stroke(a, b) for a, b in itertools.pairwise(ring)]
        at = ring[-1]
    return Routed(passes, InAreaRouter(area))


def contour_points(builder: PathBuilder, routed: Routed) -> list[RoutePoint]:
    """The route's points; a stop where one side ends and the next begins is made once."""
    points = builder.build(routed.passes, routed.transits)
    if builder.fly_through:
        return points  # a side's end and the next side's start switch the camera off and on
    out: list[RoutePoint] = []
    for p in points:
        if out and out[-1].xy == p.xy:
            if out[-1].kind is Kind.TRANSIT and p.kind is not Kind.TRANSIT:
                out[-1] = p
            continue
        out.append(p)
    return out
