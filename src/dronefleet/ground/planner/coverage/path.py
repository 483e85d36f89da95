"""Stage 5 of the coverage pipeline: turn the route into the points a drone flies to.

Stopping surveys (the seed's) get a waypoint every ``spacing`` metres or less along each swath,
both ends included — the seed's ``step_distance`` grid. On a footprint grid (``cell_centres``)
the stops are the centres of the swath's cells, ``spacing`` or less long, and the swath's ends
are passed without stopping: the path is the same, every point of the area is as near a stop as
before (half a cell's diagonal), and each swath has one stop fewer. Fly-through surveys get only
each swath's two ends; the camera fires on distance in between. Transits between swaths bend
round holes and concavities (:mod:`.router`, :mod:`.transits`); :mod:`.gaps` then adds spurs
where the swaths leave a gap.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
import shapely
from shapely.geometry import LineString, Point

from dronefleet.ground.planner.coverage.route import Flown, Transits
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

    def build(self, passes: list[Flown], router: Transits) -> list[RoutePoint]:
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
