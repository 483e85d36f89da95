"""The routes along a small area's outline, weighed against its swaths' (stage 4 of the
pipeline, :mod:`.pipeline`): rings all the way (:mod:`.contour`), or the outline flown once and
swaths inside it (:mod:`.headland`). Both are offered on the same terms (:func:`offered`: few
spacing-squares, few corners), are closed by the pipeline's gap filler, and are chosen over
the swaths only as the module's functions say.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from shapely.geometry import Polygon

from dronefleet.ground.planner.coverage.candidate import SAME_TIME, Candidate, beaten, chosen
from dronefleet.ground.planner.coverage.contour import contour_points, contour_route
from dronefleet.ground.planner.coverage.gaps import GapFiller
from dronefleet.ground.planner.coverage.headland import headland_options, least_m
from dronefleet.ground.planner.coverage.path import RoutePoint
from dronefleet.ground.planner.coverage.route import Routed
from dronefleet.ground.planner.coverage.spec import AreaSpec
from dronefleet.ground.planner.coverage.swaths import SwathGenerator

if TYPE_CHECKING:
    from dronefleet.ground.planner.coverage.pipeline import CoveragePipeline

#: The sweep angle a contour route is given: 90° is the local plane itself (no rotation).
CONTOUR_ANGLE = 90.0

#: Outlines with more vertices than this are not offered rings: a traced 240-vertex outline's
#: rings and their gaps took 115 ms more to plan and never won.
CONTOUR_VERTICES = 100

#: Inner swath angles a headland route is tried at (:func:`or_headland`).
HEADLAND_ANGLES = 3

#: Largest area (in spacing-squares, see SHORTLIST) whose gaps are closed by detours first.
DETOUR_SQUARES = 260


def or_contour(
    pipe: CoveragePipeline,
    spec: AreaSpec,
    area: Polygon,
    first: tuple[float, float],
    best: Candidate,
    filler: GapFiller | None,
) -> Candidate:
    """The contour route (:mod:`.contour`) where it is clearly quicker than ``best``, the
    swaths' route: by more than :data:`~.candidate.SAME_TIME`, the closed form's margin.
    Small areas only (:data:`DETOUR_SQUARES`): a ring's gaps are closed by detours."""
    builder = best.builder
    if not offered(area, builder.spacing_m):
        return best
    routed = contour_route(area, builder.spacing_m, first)
    if routed is None:
        return best
    ring = Candidate(CONTOUR_ANGLE, area, [], builder, first, routed, hold_s=best.hold_s)
    ring.pattern = "rings"
    ring.points = contour_points(builder, routed)
    pipe._cost(spec, best)
    beat = best.time_s * (1.0 - SAME_TIME)

    def over(points: list[RoutePoint]) -> bool:
        return pipe.timing.of(points, ring.hold_s) >= beat

    if over(ring.points):
        return best
    if filler is not None:
        pipe.close_gaps(ring, filler, over)
    pipe._cost(spec, ring)
    return ring if ring.time_s < beat else best


def or_headland(
    pipe: CoveragePipeline,
    spec: AreaSpec,
    area: Polygon,
    first: tuple[float, float],
    best: Candidate,
    filler: GapFiller | None,
) -> Candidate:
    """The headland route (:mod:`.headland`) where it is :func:`chosen` over ``best``: as
    quick within :data:`~.candidate.SAME_TIME` and shorter, or quicker by more. Small areas
    only, as rings (:data:`DETOUR_SQUARES`, :data:`CONTOUR_VERTICES`).

    Its inner swaths are tried at :data:`HEADLAND_ANGLES` angles, ranked as the swaths'
    angles are (the pipeline's ``_guess``: a spur to each gap) and closed in that order while
    they can still be chosen (:func:`beaten`, closing gaps only adds to a route). An option
    that can no longer be chosen by what any route through its passes is at least
    (:func:`least_m`), or by its route before its gaps, is dropped before it is routed or
    guessed."""
    builder = best.builder
    if not offered(area, builder.spacing_m):
        return best
    swaths = SwathGenerator(builder.spacing_m)
    pipe._cost(spec, best)
    done = [(best.time_s, best.length_m)]
    found: list[Candidate] = []
    base: Routed | None = None  # the options share their sides: their transits are reused
    for passes in headland_options(area, swaths, pipe.angles, HEADLAND_ANGLES):
        least = least_m(passes) if passes else math.inf
        if beaten(least / pipe.timing.speed_mps, least, done):
            continue
        routed = base = pipe.orderer.reorder(list(passes), [], first, area, base)
        head = Candidate(CONTOUR_ANGLE, area, [], builder, first, routed, hold_s=best.hold_s)
        head.pattern = "headland"  # the outline flown once, then swaths inside
        head.points = contour_points(builder, routed)
        pipe._cost(spec, head)
        if beaten(head.time_s, head.length_m, done):
            continue
        head.guess = head.time_s
        if filler is not None:
            pipe._guess(head, filler)
        found.append(head)
    closed = [best]
    for head in sorted(found, key=lambda c: c.guess):
        done = [(c.time_s, c.length_m) for c in closed]
        if beaten(head.time_s, head.length_m, done):
            continue
        if filler is not None:
            pipe.close_gaps(head, filler, pipe._beaten(head, done))
            pipe._cost(spec, head)
            if _uncovered(head) > max(filler.leave_m2, _uncovered(best)):
                continue  # gaps the filler's rounds could not close: never less covered
        closed.append(head)
    return chosen(closed)


def offered(area: Polygon, spacing_m: float) -> bool:
    """Whether ``area`` is small enough to be offered its outline's routes: at most
    :data:`DETOUR_SQUARES` spacing-squares (their gaps are closed by detours) and
    :data:`CONTOUR_VERTICES` corners."""
    return area.area / spacing_m**2 <= DETOUR_SQUARES and vertices(area) <= CONTOUR_VERTICES


def vertices(area: Polygon) -> int:
    """The corners of an area's outline and holes (each ring's closing one counted)."""
    return len(area.exterior.coords) + sum(len(r.coords) for r in area.interiors)


def _uncovered(c: Candidate) -> float:
    """What ``c`` leaves uncovered (m²)."""
    return float(sum(g.area for g in c.left))
