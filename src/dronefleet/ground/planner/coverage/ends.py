"""The route's two ends pulled in when the coverage target leaves room (after the gaps are closed).

A route starts and ends on a swath's end, half a spacing inside the field. On the footprint
grid a stopping survey's first and last stops are the centres of their cells, half a spacing
further in: the way from the swath's end to that stop (and from the last stop out) photographs
nothing. Flying through, the camera run may start and end that much further in as well. Below a
100 % target (:class:`~.gaps.GapFiller`'s allowance), each end is pulled in by that half spacing
when what it then leaves is slivers within what is left of the allowance: a U-shaped field at
98.2 % flies 10 m less (2191 -> 2181 m).
"""

from __future__ import annotations

import math

from shapely.geometry import Polygon

from dronefleet.ground.planner.coverage.gaps import GapFiller
from dronefleet.ground.planner.coverage.path import Kind, RoutePoint

#: Most of the allowance the two ends may leave uncovered, with what the route left already.
#: The gap finder measures the band with a tolerance; half keeps a field near its target (a
#: pond at 99.9 %, allowed 12.9 m²) where it was.
END_SHARE = 0.5


def trimmed(
    points: list[RoutePoint], area: Polygon, left: list[Polygon], filler: GapFiller
) -> tuple[list[RoutePoint], list[Polygon]]:
    """``points`` with the end, then the start, pulled in where the allowance lets it, and the
    gaps then left (``left`` unchanged when neither is)."""
    if filler.leave_m2 <= 0 or len(points) < 3:
        return points, left
    for last in (True, False):
        shorter = _pulled(points, filler, last)
        if shorter is None:
            continue
        gaps = filler.gaps(shorter, area)
        total = sum(g.area_m2 for g in gaps)
        if total > END_SHARE * filler.leave_m2:
            continue
        # Every gap must be one the target lets the route leave: a sliver.
        if len(filler.slivers(shorter, gaps, filler.leave_m2)) < len(gaps):
            continue
        points, left = shorter, [g.shape for g in gaps]
    return points, left


def _pulled(points: list[RoutePoint], filler: GapFiller, last: bool) -> list[RoutePoint] | None:
    """``points`` with one end pulled in by half a spacing, or None when it cannot be."""
    route = points[::-1] if last else points
    first, second = route[0], route[1]
    builder = filler.builder
    if first.kind is Kind.TRANSIT and second.kind is Kind.WORK:
        out = route[1:]  # a footprint grid's swath end: start at the first stop
    elif not last and first.kind is Kind.SWATH_START and second.kind is Kind.SWATH_END:
        run = _inward(first, second, builder.spacing_m / 2.0)
        if run is None:
            return None
        out = [*builder.along(run, second.xy), *route[2:]]
    elif last and first.kind is Kind.SWATH_END and second.kind is Kind.SWATH_START:
        run = _inward(first, second, builder.spacing_m / 2.0)
        if run is None:
            return None
        out = [*builder.along(second.xy, run)[::-1], *route[2:]]
    else:
        return None
    return out[::-1] if last else out


def _inward(end: RoutePoint, other: RoutePoint, by_m: float) -> tuple[float, float] | None:
    """The point ``by_m`` from ``end`` towards ``other`` (None if the run is not longer)."""
    length = math.dist(end.xy, other.xy)
    if length <= 2.0 * by_m:
        return None
    f = by_m / length
    return end.x + (other.x - end.x) * f, end.y + (other.y - end.y) * f
