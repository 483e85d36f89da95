"""Stage 5 of the coverage pipeline: turn the route into the points a drone flies to.

Stopping surveys (the seed's) get a waypoint every ``spacing`` metres or less along each swath,
both ends included — the seed's ``step_distance`` grid. On a footprint grid (``cell_centres``)
the stops are the centres of the swath's cells, ``spacing`` or less long, and the swath's ends
are passed without stopping: the path is the same, every point of the area is as near a stop as
before (half a cell's diagonal), and each swath has one stop fewer. Fly-through surveys get only
each swath's two ends; the camera fires on distance in between. Transits between swaths bend
round holes and concavities (:mod:`.router`). Finally :class:`GapFiller` checks the promise that
every point of the area lies within half a spacing of the path, and where it does not (a spike
between two swaths, a corner a swath misses) adds a short out-and-back spur inside the area.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
import shapely
from shapely.geometry import LineString, Point, Polygon

from dronefleet.ground.planner.coverage.route import Pass
from dronefleet.ground.planner.coverage.router import InAreaRouter
from dronefleet.ground.planner.coverage.swaths import slack_m

#: Fly-through: swath ends are reached within this (m), so pictures land where planned.
END_TOLERANCE_M = 0.5
#: Fly-through: the last picture of a swath is due this far (m) before its end, so the
#: distance trigger has fired before the drone is within END_TOLERANCE_M of it.
TRIGGER_MARGIN_M = 2.0


XY = tuple[float, float]


class Kind(StrEnum):
    WORK = "work"  # stop here and do the intermediate action
    SWATH_START = "swath_start"  # fly-through: the camera trigger goes on here
    SWATH_END = "swath_end"  # fly-through: and off here
    TRANSIT = "transit"  # a bend on the way (round a hole or a concavity)


@dataclass
class RoutePoint:
    x: float
    y: float
    kind: Kind
    trigger_m: float = 0.0  # SWATH_START: distance between pictures along this swath
    photos: int = 0  # pictures expected at / from this point

    @property
    def xy(self) -> tuple[float, float]:
        return self.x, self.y


@dataclass(frozen=True)
class PathBuilder:
    spacing_m: float
    fly_through: bool = False
    trigger_m: float = 0.0
    photo_at_work: bool = False
    cell_centres: bool = False

    def _work(self, a: XY, b: XY) -> list[RoutePoint]:
        length = math.dist(a, b)
        n = math.ceil((length - slack_m(self.spacing_m)) / self.spacing_m)
        photo = int(self.photo_at_work)
        if n <= 0:
            return [RoutePoint((a[0] + b[0]) / 2, (a[1] + b[1]) / 2, Kind.WORK, photos=photo)]
        dx, dy = (b[0] - a[0]) / n, (b[1] - a[1]) / n
        if self.cell_centres:
            stops = [
                RoutePoint(a[0] + (k + 0.5) * dx, a[1] + (k + 0.5) * dy, Kind.WORK, photos=photo)
                for k in range(n)
            ]
            return [RoutePoint(*a, Kind.TRANSIT), *stops, RoutePoint(*b, Kind.TRANSIT)]
        return [
            RoutePoint(a[0] + k * dx, a[1] + k * dy, Kind.WORK, photos=photo) for k in range(n + 1)
        ]

    def along(self, a: XY, b: XY) -> list[RoutePoint]:
        """The points that cover the straight pass from ``a`` to ``b``."""
        if not self.fly_through:
            return self._work(a, b)
        usable = math.dist(a, b) - TRIGGER_MARGIN_M
        if usable < max(self.trigger_m / 2.0, TRIGGER_MARGIN_M):
            return self._work(a, b)  # too short to fly through: stop and shoot
        gaps = math.ceil((usable - slack_m(self.trigger_m)) / self.trigger_m)
        return [
            RoutePoint(*a, Kind.SWATH_START, trigger_m=usable / gaps, photos=gaps + 1),
            RoutePoint(*b, Kind.SWATH_END),
        ]

    def build(self, passes: list[Pass], router: InAreaRouter) -> list[RoutePoint]:
        points: list[RoutePoint] = []
        for p in passes:
            if points:
                points += transit(router.path(points[-1].xy, p.start))
            points += self.along(p.start, p.end)
        return points


def transit(path: list[XY]) -> list[RoutePoint]:
    """The bends of a routed transit (its ends are route points already)."""
    return [RoutePoint(x, y, Kind.TRANSIT) for x, y in path[1:-1]]


def route_xy(points: list[RoutePoint]) -> np.ndarray:
    """The points' coordinates as an (n, 2) array."""
    flat = np.fromiter(itertools.chain.from_iterable((p.x, p.y) for p in points), float)
    return flat.reshape(-1, 2)


def polyline(points: list[RoutePoint]) -> shapely.Geometry:
    xy = [pt.xy for pt in points]
    return LineString(xy) if len(xy) > 1 else Point(xy[0])


@dataclass(frozen=True)
class GapFiller:
    """Adds spurs until every point of the area is within ``radius_m`` (+ tolerance) of the path.

    A spur flies from the nearest route point to one end of the gap, across it to its far end
    (covered like a swath), and back: one spur closes a long thin gap (a corner a swath misses).
    """

    radius_m: float
    tolerance_m: float
    builder: PathBuilder
    max_rounds: int = 12

    def gaps(self, points: list[RoutePoint], area: Polygon) -> list[tuple[XY, XY, float]]:
        """Uncovered pieces: (near end, far end) of a spur that would close each, its area.

        The buffer is ``radius + tol``; a piece counts when a point of its boundary (sampled
        every 2·tol) is beyond ``radius + 1.5·tol`` or its inscribed circle is wider than tol,
        so whatever passes is within ``radius + 3.5·tol`` of the path.
        """
        xy = _corners(points)
        path = LineString(xy) if len(xy) > 1 else Point(xy[0])
        tol = self.tolerance_m
        covered = _band(xy, self.radius_m + tol)
        found = []
        for gap in shapely.get_parts(area.difference(covered)):
            if gap.geom_type != "Polygon" or gap.area < tol * tol / 16:
                continue  # float dust where the buffer meets the edge
            dense = shapely.segmentize(gap, 2 * tol)
            coords = np.vstack([np.asarray(r.coords) for r in (dense.exterior, *dense.interiors)])
            k, far = _farthest(coords, _near(path, gap, self.radius_m + tol))
            if far > self.radius_m + 1.5 * tol:
                tip = coords[k]
            else:  # the boundary is covered; is the inside (a strip between two passes)?
                circle = shapely.maximum_inscribed_circle(gap, tol / 4)
                if circle.length <= tol:
                    continue  # a sliver along the covered edge
                tip = np.asarray(circle.coords[0])
                tip = coords[int(np.argmax(np.hypot(*(coords - tip).T)))]
            other = coords[int(np.argmax(np.hypot(*(coords - tip).T)))]
            near, far_end = (float(other[0]), float(other[1])), (float(tip[0]), float(tip[1]))
            found.append((near, far_end, float(gap.area)))
        return found

    def fill(
        self, points: list[RoutePoint], area: Polygon, router: InAreaRouter
    ) -> tuple[list[RoutePoint], float]:
        """The points with spurs added, and the area (m²) still uncovered (normally 0)."""
        points = list(points)
        for _ in range(self.max_rounds):
            gaps = self.gaps(points, area)
            if not gaps:
                return points, 0.0
            xy = route_xy(points)
            # Never inside a fly-through swath (that would break the camera run).
            allowed = np.array([p.kind is not Kind.SWATH_START for p in points])
            inserts = [self._spur(points, xy, allowed, near, far, router) for near, far, _ in gaps]
            for k, extra in sorted(inserts, key=lambda item: -item[0]):
                points[k + 1 : k + 1] = extra
        return points, sum(a for _, _, a in self.gaps(points, area))

    def _spur(
        self,
        points: list[RoutePoint],
        xy: np.ndarray,
        allowed: np.ndarray,
        near: XY,
        far: XY,
        router: InAreaRouter,
    ) -> tuple[int, list[RoutePoint]]:
        gap = np.where(allowed, np.hypot(xy[:, 0] - near[0], xy[:, 1] - near[1]), np.inf)
        k = int(np.argmin(gap))  # the first of the nearest, as min() took it
        here = points[k].xy
        out: list[RoutePoint] = transit(router.path(here, near))
        across = router.path(near, far)
        for a, b in itertools.pairwise(across):
            piece = self.builder.along(a, b)
            if out and out[-1].kind is Kind.WORK and out[-1].xy == piece[0].xy:
                piece = piece[1:]  # the bend is a waypoint already
            out += piece
        out += transit(router.path(far, here))
        return k, [*out, RoutePoint(*here, Kind.TRANSIT)]


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


def _corners(points: list[RoutePoint]) -> np.ndarray:
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
    (:func:`_corners`, which the caller gives): the 1 km² field at 10 m in stop mode has 10,397
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
