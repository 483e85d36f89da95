"""A headland route: the outline flown once, half a spacing inside, and swaths over the rest.

The third pattern the pipeline weighs on small areas (:func:`~.outlines.or_headland`),
between swaths all the way (:mod:`.swaths`) and rings all the way (:mod:`.contour`).
Sharp tips are where swaths lose: a five-pointed star's 36° tips cost its
swaths 68 m of detours and spurs (444 -> 513 m at 100 %, bench/coverage_vs_f2c.py), since a
swath crossing a tip ends short of its point whichever way it runs. Flown along its sides, a tip
costs what it covers: each side half a spacing in, the corner moved out to within half a spacing
of the field's (:func:`~.contour.pointed`). Rings all the way lose the middle instead: each
ring's reflex corners are mitred inward (a star's by 6 m), so the next ring starts far from the
first and leaves a pentagram of slivers between them (docs/DESIGN.md).

So the sides here are the outline's edges each offset half a spacing in (a bevelled negative
buffer) and nothing more: at a reflex corner the two sides just end, half a spacing from the
corner, which their ends cover; the bevel between them is not flown, so the route solver
(:mod:`.route`) may join the sides however is shortest, not round the ring. What the sides leave
is then covered by swaths at the angle that suits it (:mod:`.angle`), and :mod:`.gaps` closes
the rest as for any route. On the star: 484 m in either mode, against its swaths' 513 / 516 m,
for the same 100 % (Fields2Cover: 483 m leaving 2.5 % uncovered).
"""

from __future__ import annotations

import itertools

import numpy as np
import shapely
from shapely.geometry import MultiPolygon, Polygon
from shapely.geometry.polygon import orient

from dronefleet.ground.planner.coverage.angle import AngleChooser
from dronefleet.ground.planner.coverage.contour import SIMPLIFY, pointed
from dronefleet.ground.planner.coverage.route import Stroke
from dronefleet.ground.planner.coverage.router import reflex_corners
from dronefleet.ground.planner.coverage.swaths import SwathGenerator, from_sweep_xy, to_sweep

XY = tuple[float, float]

#: Pieces the sides leave smaller than this fraction of a spacing-square get no swaths: the gap
#: filler's detours close such crumbs for less than a swath's turns.
CRUMB = 0.01
#: A bevel's ends are half a spacing from the reflex corner; this much slack (a fraction).
BEVEL_SLACK = 0.01


def sides(area: Polygon, spacing_m: float) -> list[Stroke]:
    """The outline's (and holes') edges half a spacing inside, convex corners pointed; the bevels
    at reflex corners are left out (see the module docstring)."""
    cover = area.buffer(1e-6)
    inner = area.buffer(-spacing_m / 2.0, join_style="bevel")
    reflex = np.asarray(reflex_corners(area), dtype=float).reshape(-1, 2)
    near = spacing_m / 2.0 * (1.0 + BEVEL_SLACK)
    out: list[Stroke] = []
    parts = inner.geoms if isinstance(inner, MultiPolygon) else [inner]
    for part in parts:
        if part.is_empty:
            continue
        part = orient(part)  # exterior anticlockwise, holes clockwise (see pointed)
        for ring in (part.exterior, *part.interiors):
            corners = [(float(x), float(y)) for x, y in ring.simplify(SIMPLIFY * spacing_m).coords]
            corners = pointed(corners[:-1], spacing_m / 2.0, cover)
            for a, b in itertools.pairwise([*corners, corners[0]]):
                if a != b and not _bevel(a, b, reflex, near):
                    out.append(Stroke(a, b))
    return out


def _bevel(a: XY, b: XY, reflex: np.ndarray, near: float) -> bool:
    """Whether a side from ``a`` to ``b`` is the bevel of a reflex corner: both its ends within
    ``near`` (half a spacing) of the same corner."""
    if not len(reflex):
        return False
    da = np.hypot(reflex[:, 0] - a[0], reflex[:, 1] - a[1])
    db = np.hypot(reflex[:, 0] - b[0], reflex[:, 1] - b[1])
    return bool(np.any((da < near) & (db < near)))


def left_by(area: Polygon, flown: list[Stroke], spacing_m: float) -> list[Polygon]:
    """The pieces of ``area`` farther than half a spacing from the ``flown`` sides, largest
    first (crumbs left out, see :data:`CRUMB`)."""
    if not flown:
        return [area]
    legs = shapely.linestrings([[s.start, s.end] for s in flown])
    band = shapely.union_all(shapely.buffer(legs, spacing_m / 2.0))
    rest = area.difference(band)
    pieces = [p for p in shapely.get_parts(rest) if isinstance(p, Polygon)]
    pieces = [p for p in pieces if p.area >= CRUMB * spacing_m**2]
    return sorted(pieces, key=lambda p: -p.area)


def inner_angles(
    pieces: list[Polygon], swaths: SwathGenerator, chooser: AngleChooser, size: int
) -> list[float]:
    """Up to ``size`` swath angles for what the sides leave, shortlisted for its largest piece
    (:meth:`~.angle.AngleChooser.shortlist`). The quick key alone picks badly here: a star's
    middle keys best at 51° from north (491 m once its gaps are closed), where its tips' axes
    (0°, 36°, the across of a hull side) give 484 m."""
    return chooser.shortlist(pieces[0], swaths, size) if pieces else [0.0]


def inner_swaths(pieces: list[Polygon], swaths: SwathGenerator, angle: float) -> list[Stroke]:
    """Swaths at ``angle`` across each piece, as strokes in the local plane."""
    out: list[Stroke] = []
    for piece in pieces:
        for line in swaths.lines(to_sweep(piece, angle)):
            for x0, x1 in line.segments:
                a, b = from_sweep_xy(x0, line.y, angle), from_sweep_xy(x1, line.y, angle)
                out.append(Stroke(a, b))
    return out


def headland_options(
    area: Polygon, swaths: SwathGenerator, chooser: AngleChooser, size: int
) -> list[list[Stroke]]:
    """The headland routes' passes, unordered, one list per inner angle (up to ``size``): the
    sides, then the swaths inside them."""
    flown = sides(area, swaths.spacing_m)
    pieces = left_by(area, flown, swaths.spacing_m)
    angles = inner_angles(pieces, swaths, chooser, size)
    return [flown + inner_swaths(pieces, swaths, angle) for angle in angles]


def least_m(passes: list[Stroke]) -> float:
    """What any route through ``passes`` is at least (m): the passes themselves, and for each
    but one the way from its nearer end to the nearest end of another pass (a route leaves every
    pass but its last for another). Cheap beside routing them: the pipeline drops a headland
    that cannot win by it (a pond's: 1680 m at least against its swaths' 1546 m route)."""
    ends = np.array([[p.start, p.end] for p in passes], dtype=float)  # (n, 2 ends, 2)
    work = float(np.hypot(*(ends[:, 1] - ends[:, 0]).T).sum())
    if len(passes) < 2:
        return work
    flat = ends.reshape(-1, 2)
    d = np.hypot(*(flat[:, None, :] - flat[None, :, :]).transpose(2, 0, 1))
    owner = np.repeat(np.arange(len(passes)), 2)
    d[owner[:, None] == owner[None, :]] = np.inf  # a pass's own ends
    nearest = d.min(axis=1).reshape(-1, 2).min(axis=1)
    return work + float(nearest.sum() - nearest.max())
