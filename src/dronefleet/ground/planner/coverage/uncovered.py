"""What a route leaves uncovered: the gaps in its footprint, found and measured.

Every point of the area should lie within half a spacing of the path (the footprint of a swath).
:func:`find_gaps` finds each uncovered piece of the area as a :class:`Gap`, with the ends of the
spur that would close it (its farthest boundary point from the path, and the point opposite).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.geometry import LineString, Point, Polygon

from dronefleet.ground.planner.coverage.path import XY, RoutePoint, route_xy


@dataclass(frozen=True)
class Gap:
    """An uncovered piece: the ends of the spur that would close it, its area and shape, and
    its outline sampled every two tolerances (what :func:`find_gaps` measured, kept for the
    detours: sampling it again for each was a tenth of their time)."""

    near: XY
    far: XY
    area_m2: float
    shape: Polygon
    outline: np.ndarray | None = field(default=None, compare=False, repr=False)

    def sampled(self, step_m: float) -> np.ndarray:
        """The outline with a point every ``step_m`` (find_gaps' two tolerances: kept)."""
        return outline(self.shape, step_m) if self.outline is None else self.outline


def find_gaps(
    points: list[RoutePoint], area: Polygon, radius_m: float, tolerance_m: float
) -> list[Gap]:
    """Uncovered pieces, with the (near end, far end) of a spur that would close each.

    The buffer is ``radius + tol``; a piece counts when a point of its boundary (sampled
    every 2·tol) is beyond ``radius + 1.5·tol`` or its inscribed circle is wider than tol,
    so whatever passes is within ``radius + 3.5·tol`` of the path.
    """
    xy = corners(points)
    path = LineString(xy) if len(xy) > 1 else Point(xy[0])
    tol = tolerance_m
    covered = _band(xy, radius_m + tol)
    found = []
    for gap in shapely.get_parts(area.difference(covered)):
        if gap.geom_type != "Polygon" or gap.area < tol * tol / 16:
            continue  # float dust where the buffer meets the edge
        coords = outline(gap, 2 * tol)
        k, far = _farthest(coords, _near(path, gap, radius_m + tol))
        if far > radius_m + 1.5 * tol:
            tip = coords[k]
        else:  # the boundary is covered; is the inside (a strip between two passes)?
            circle = shapely.maximum_inscribed_circle(gap, tol / 4)
            if circle.length <= tol:
                continue  # a sliver along the covered edge
            tip = np.asarray(circle.coords[0])
            tip = coords[int(np.argmax(np.hypot(*(coords - tip).T)))]
        other = coords[int(np.argmax(np.hypot(*(coords - tip).T)))]
        near, far_end = (float(other[0]), float(other[1])), (float(tip[0]), float(tip[1]))
        found.append(Gap(near, far_end, float(gap.area), gap, coords))
    return found


def outline(shape: Polygon, step_m: float) -> np.ndarray:
    """The coordinates of ``shape``'s rings (exterior first) with a point every ``step_m``."""
    return shapely.get_coordinates(shapely.segmentize(shape, step_m))


def _near(path: shapely.Geometry, gap: Polygon, reach_m: float) -> shapely.Geometry:
    """The part of ``path`` that can be nearest to a point of ``gap``.

    Measuring a gap against the whole route (thousands of vertices) for each of hundreds of
    gaps was most of a spiky area's planning time. A gap touches the covered band, so each of
    its points is within its diagonal + ``reach_m`` of the path: the path clipped to the gap's
    box grown by that much holds the nearest point of every point of the gap, and the
    distances come out the same."""
    minx, miny, maxx, maxy = gap.bounds
    grow = math.hypot(maxx - minx, maxy - miny) + reach_m + 1e-6
    part = shapely.clip_by_rect(path, minx - grow, miny - grow, maxx + grow, maxy + grow)
    return path if part.is_empty else part


#: Boundary samples measured first by :func:`_farthest`: one in this many.
COARSE = 16


def _farthest(coords: np.ndarray, path: shapely.Geometry) -> tuple[int, float]:
    """The first of ``coords`` farthest from ``path``, and its distance.

    A comb's gaps are long and sampled every few centimetres: measuring every sample was half
    of its planning. Distance to the path changes no faster than position (|d(p) - d(q)| <=
    |p - q|), so one sample in COARSE is measured first; a sample can only be the farthest if
    the measured one before it plus the way between them reaches the farthest measured, and
    only those are measured too. The answer is the one measuring every sample would give."""
    coarse = np.arange(0, len(coords), COARSE)
    d = shapely.distance(shapely.points(coords[coarse]), path)
    best = float(d.max())
    owner = np.arange(len(coords)) // COARSE
    bound = d[owner] + np.hypot(*(coords - coords[coarse][owner]).T)
    maybe = np.flatnonzero(bound >= best)
    exact = shapely.distance(shapely.points(coords[maybe]), path)
    k = int(np.argmax(exact))
    return int(maybe[k]), float(exact[k])


#: Route points per piece when buffering the route (see :func:`_band`).
BAND_PIECE = 16


#: Route points closer than this to the line through their neighbours add nothing to its band.
STRAIGHT_M = 1e-6


def corners(points: list[RoutePoint]) -> np.ndarray:
    """The route's vertices without the ones on a straight run (a stop-mode swath is a point
    every few metres on one line): the same line, in a fraction of the vertices."""
    xy = route_xy(points)
    if len(xy) < 3:
        return xy
    line = shapely.simplify(LineString(xy), STRAIGHT_M, preserve_topology=False)
    return np.asarray(line.coords) if not line.is_empty and len(line.coords) > 1 else xy


def _band(xy: np.ndarray, radius_m: float) -> shapely.Geometry:
    """Everything within ``radius_m`` of the route.

    GEOS buffers one long zigzagging line slowly (a 9000-point route over a spiky area: 1.9 s,
    most of its planning); the same band is the union of the buffers of short consecutive
    pieces sharing their ends, which GEOS builds in a tenth of the time. Pieces of 16 points
    were the fastest of 16 to 256 on that route. Points on straight runs are dropped first
    (:func:`corners`, which the caller gives): the 1 km² field at 10 m in stop mode has 10,397
    points and 270 corners."""
    # A spur flies out to a gap and back along the same line; GEOS buffers a line that doubles
    # back on itself wrongly (a property test found a 0.4 m² hole at a spur's tip, every round
    # of spurs adding the same spur again), so every piece ends at such a turn.
    tips: list[int] = []
    if len(xy) > 2:
        tips = (np.flatnonzero(np.all(xy[:-2] == xy[2:], axis=1)) + 1).tolist()
    if len(xy) < 2 * BAND_PIECE and len(tips) == 0:
        geometry = LineString(xy) if len(xy) > 1 else Point(xy[0])
        return geometry.buffer(radius_m, quad_segs=16)
    cuts = sorted({*range(0, len(xy) - 1, BAND_PIECE), *tips, len(xy) - 1})
    pieces = [LineString(xy[a : b + 1]) for a, b in itertools.pairwise(cuts)]
    return shapely.union_all(shapely.buffer(pieces, radius_m, quad_segs=16))
