"""Stage 6 of the coverage pipeline: close the gaps the swaths leave, up to the coverage target.

Every point of the area should lie within half a spacing of the path (the footprint of a swath).
Swaths at one angle miss some: a spike between two swaths, a corner a swath ends short of, the
tips of a star. :class:`GapFiller` finds each uncovered piece (:mod:`.uncovered`) and closes it
with a detour of a leg through it (:mod:`.detours`) or a short spur inside the area that flies
across it.

The operator's coverage target (``AreaSpec.coverage_target_pct``, default 100) says how much of
the area must be covered. Below 100 % the filler may leave *slivers* — gaps narrower than
:data:`SLIVER_SPACINGS` spacings (their widest inscribed circle), where a spur flies far for
little area, like a star's tips — as long as what is left stays within the allowance; it leaves
the ones whose spurs would cost most per square metre first. The gaps left (and any the rounds
could not close) are returned, so the plan can say how much is uncovered and where.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import LineString, Point, Polygon

from dronefleet.ground.planner.coverage.detours import Detours
from dronefleet.ground.planner.coverage.path import (
    XY,
    Kind,
    PathBuilder,
    RoutePoint,
    route_xy,
    transit,
)
from dronefleet.ground.planner.coverage.route import Stroke, Transits
from dronefleet.ground.planner.coverage.uncovered import Gap, corners, find_gaps

#: A gap narrower than this many spacings (its widest inscribed circle) is a sliver, which a
#: coverage target below 100 % may leave uncovered.
SLIVER_SPACINGS = 1.0
#: Most gaps in a round whose spurs are fitted to them (shortened to what covers the gap).
FITTED_SPURS = 24
#: Most route points for detours (each gap measures every leg): past it, a square kilometre
#: in stop mode (10,000 points), gaps get spurs as before.
DETOUR_POINTS = 2_000


@dataclass(frozen=True)
class GapFiller:
    """Adds spurs until every point of the area is within ``radius_m`` (+ tolerance) of the
    path, except slivers narrower than ``sliver_m`` totalling at most ``leave_m2``.

    A spur flies from the nearest route point to one end of the gap, across it to its far end
    (covered like a swath), and back: one spur closes a long thin gap (a corner a swath misses).
    """

    radius_m: float
    tolerance_m: float
    builder: PathBuilder
    max_rounds: int = 12
    leave_m2: float = 0.0
    sliver_m: float = 0.0
    detours: bool = True  # bend the route's legs through gaps (else spurs only)

    def gaps(self, points: list[RoutePoint], area: Polygon) -> list[Gap]:
        """Uncovered pieces, with the (near end, far end) of a spur that would close each
        (:func:`~.uncovered.find_gaps`)."""
        return find_gaps(points, area, self.radius_m, self.tolerance_m)

    def strokes(
        self, points: list[RoutePoint], area: Polygon, gaps: list[Gap] | None = None
    ) -> tuple[list[Stroke], list[Polygon], float]:
        """A stroke across each gap (``gaps``, default: found here), for the solver to weave
        into the route; and the slivers the coverage target lets the route leave, with what is
        left of the allowance."""
        gaps = self.gaps(points, area) if gaps is None else gaps
        kept = self.slivers(points, gaps, self.leave_m2) if self.leave_m2 > 0 else []
        budget = self.leave_m2 - sum(g.area_m2 for g in kept)
        cover = area.buffer(1e-6)
        out = []
        for g in gaps:
            if any(g is k for k in kept):
                continue
            stroke = self._stroke(g, cover)
            if stroke is not None:
                out.append(stroke)
        return out, [g.shape for g in kept], budget

    def _stroke(self, gap: Gap, cover: shapely.Geometry) -> Stroke | None:
        """The shortest of a few strokes along the gap (near to far) that covers it."""
        (x0, y0), (x1, y1) = gap.near, gap.far
        length = math.hypot(x1 - x0, y1 - y0)
        if length < 1e-9:
            return Stroke(gap.near, gap.far)
        ux, uy = (x1 - x0) / length, (y1 - y0) / length
        reach = self.radius_m + self.tolerance_m
        for pull in (0.8 * self.radius_m, 0.4 * self.radius_m, 0.0):
            pull = min(pull, length / 2.0)
            a = (x0 + ux * pull, y0 + uy * pull)
            b = (x1 - ux * pull, y1 - uy * pull)
            line = LineString([a, b]) if a != b else Point(a)
            if not cover.covers(line):
                return None
            if gap.shape.difference(line.buffer(reach, quad_segs=8)).area <= self.tolerance_m**2:
                return Stroke(a, b)
        return Stroke(gap.near, gap.far)

    def fill(
        self,
        points: list[RoutePoint],
        area: Polygon,
        router: Transits,
        left: list[Polygon] | None = None,
        budget: float | None = None,
        over: Callable[[list[RoutePoint]], bool] | None = None,
        first: list[Gap] | None = None,
    ) -> tuple[list[RoutePoint], list[Polygon]]:
        """The points with spurs added, and the gaps left uncovered (none at a 100 % target);
        ``left`` are gaps already left, ``budget`` what may still be (default: the allowance).
        ``over``: whether a route is past what it may cost; closing only adds to a route, so
        once one is, the filler stops closing gaps by detours there (the gaps not yet closed
        are returned as left: a candidate angle that cannot win is not finished). ``first``:
        the gaps of ``points`` if already found (the angle's guess found them)."""
        points = list(points)
        left = list(left or [])
        budget = self.leave_m2 if budget is None else budget
        cover: shapely.Geometry | None = None
        for _ in range(self.max_rounds):
            found = self.gaps(points, area) if first is None else first
            first = None
            gaps = [g for g in found if not _among(g, left)]
            if gaps and budget > 0:
                kept = self.slivers(points, gaps, budget)
                left += [g.shape for g in kept]
                budget -= sum(g.area_m2 for g in kept)
                gaps = [g for g in gaps if not any(g is k for k in kept)]
            if not gaps:
                return points, [g.shape for g in found]
            if len(gaps) <= FITTED_SPURS and self.detours and len(points) <= DETOUR_POINTS:
                if cover is None:
                    cover = area.buffer(1e-6)
                    shapely.prepare(cover)
                # One at a time, largest first: each sees the detours before it, and a small gap
                # is often closed by a large one's detour (the next round finds it gone).
                ranked = sorted(gaps, key=lambda g: -g.area_m2)
                for n, g in enumerate(ranked):
                    points = self._close(points, g, area, cover, router)
                    if over is not None and over(points):
                        return points, [g.shape for g in ranked[n + 1 :]]
                continue
            xy = route_xy(points)
            # Never inside a fly-through swath (that would break the camera run).
            allowed = np.array([p.kind is not Kind.SWATH_START for p in points])
            if cover is None and len(gaps) <= FITTED_SPURS:
                cover = area.buffer(1e-6)
            inserts = []
            for g in gaps:
                # Across the gap only as far as covers it (a star's tip: half a spacing short);
                # a traced gear's thousand spikes each get the whole way (fitting costs GEOS).
                stroke = Stroke(g.near, g.far)
                if cover is not None and len(gaps) <= FITTED_SPURS:
                    stroke = self._stroke(g, cover) or stroke
                inserts.append(self._spur(points, xy, allowed, stroke.start, stroke.end, router))
            for k, extra in sorted(inserts, key=lambda item: -item[0]):
                points[k + 1 : k + 1] = extra
        return points, [g.shape for g in self.gaps(points, area)]

    def _close(
        self,
        points: list[RoutePoint],
        gap: Gap,
        area: Polygon,
        cover: shapely.Geometry,
        router: Transits,
    ) -> list[RoutePoint]:
        """``points`` with ``gap`` closed: by the cheapest detour off a leg of the route
        (:meth:`Detours.cheapest`), else by a spur across it from the nearest route point and
        back."""
        xy = route_xy(points)
        # Across the gap only as far as covers it (a star's tip: half a spacing short).
        stroke = self._stroke(gap, cover) or Stroke(gap.near, gap.far)
        detours = Detours(self.radius_m, self.tolerance_m, self.builder)
        found = detours.cheapest(points, xy, gap, stroke, cover)
        if found is not None:
            k, leg = found
            return [*points[:k], *leg, *points[k + 2 :]]
        allowed = np.array([p.kind is not Kind.SWATH_START for p in points])
        k, extra = self._spur(points, xy, allowed, stroke.start, stroke.end, router)
        return [*points[: k + 1], *extra, *points[k + 1 :]]

    def slivers(self, points: list[RoutePoint], gaps: list[Gap], budget: float) -> list[Gap]:
        """The slivers to leave: dearest spur per square metre first, within ``budget``."""
        path = LineString(corners(points)) if len(points) > 1 else Point(points[0].xy)
        priced: list[tuple[float, int, Gap]] = []
        for g in gaps:
            if g.area_m2 > budget:
                continue
            # Only whether it is narrower than sliver_m: a twentieth of that is precise enough.
            circle = shapely.maximum_inscribed_circle(
                g.shape, max(self.tolerance_m, self.sliver_m / 20)
            )
            if 2.0 * circle.length >= self.sliver_m:
                continue
            spur_m = 2.0 * float(shapely.distance(Point(g.far), path))
            priced.append((-spur_m / max(g.area_m2, 1e-9), len(priced), g))
        kept = []
        for _, _, g in sorted(priced, key=lambda item: item[:2]):
            if g.area_m2 <= budget:
                kept.append(g)
                budget -= g.area_m2
        return kept

    def _spur(
        self,
        points: list[RoutePoint],
        xy: np.ndarray,
        allowed: np.ndarray,
        near: XY,
        far: XY,
        router: Transits,
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


def _among(gap: Gap, left: list[Polygon]) -> bool:
    """Whether ``gap`` is (a piece of) a gap already left: spurs only ever shrink a gap."""
    point = gap.shape.representative_point()
    return any(shape.buffer(1e-6).covers(point) for shape in left)
