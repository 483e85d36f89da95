"""Stage 3 of the coverage pipeline: swaths at a spacing and an angle, and the automatic angle.

Everything here works in the *sweep frame*: the local plane rotated so that the swath bearing
points along +x; swaths are then horizontal lines ``y = offset``, clipped against the area into
segments (a concave area or one with holes gives several segments on one line). The seed's
``step_distance`` is the spacing; its vectors v and w are the grid's axes (Figure 4.28).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import shapely
from shapely import affinity
from shapely.geometry import Polygon

from dronefleet.ground.planner.coverage.spec import Grid

#: Segments shorter than this (metres) are where a line only grazes a vertex: dropped.
MIN_SEGMENT_M = 1e-6
#: The seed grid's edge lines are pulled this far inside so they cut the area, not graze it.
EDGE_EPS_M = 1e-3


def slack_m(spacing_m: float) -> float:
    """Lengths this close above a whole number of spacings count as that number (projection
    noise must not add a swath or a waypoint: 32.0001 m at 8 m is 4 spacings)."""
    return min(0.01, 0.001 * spacing_m)


def to_sweep(geom: shapely.Geometry, angle_deg: float) -> shapely.Geometry:
    """Rotate local-plane geometry so that the bearing ``angle_deg`` points along +x."""
    return affinity.rotate(geom, angle_deg - 90.0, origin=(0.0, 0.0))


def from_sweep_xy(x: float, y: float, angle_deg: float) -> tuple[float, float]:
    """A sweep-frame point back in the local plane (x east, y north)."""
    a = math.radians(90.0 - angle_deg)
    c, s = math.cos(a), math.sin(a)
    return x * c - y * s, x * s + y * c


@dataclass(frozen=True)
class SweepLine:
    """One swath line: its offset and the segments (x0 < x1) where it lies inside the area."""

    index: int
    y: float
    segments: tuple[tuple[float, float], ...]


@dataclass(frozen=True)
class SwathGenerator:
    """Parallel lines ``spacing_m`` apart across the area, clipped to it."""

    spacing_m: float
    grid: Grid = Grid.INSET

    def offsets(self, ymin: float, ymax: float) -> list[float]:
        width, s = ymax - ymin, self.spacing_m
        if self.grid == Grid.INSET:
            # Centred, so that both outer lines are at most half a spacing from the edge.
            n = max(1, math.ceil((width - slack_m(s)) / s))
            first = ymin + (width - (n - 1) * s) / 2.0
            return [first + k * s for k in range(n)]
        eps = min(EDGE_EPS_M, width / 4.0)
        inner = width - 2.0 * eps
        if inner <= 0:
            return [(ymin + ymax) / 2.0]
        n = max(1, math.ceil((inner - slack_m(s)) / s)) + 1
        step = inner / (n - 1)
        return [ymin + eps + k * step for k in range(n)]

    def lines(self, area: Polygon) -> list[SweepLine]:
        """The swath lines of ``area`` (already in the sweep frame)."""
        minx, ymin, maxx, ymax = area.bounds
        ys = self.offsets(ymin, ymax)
        cuts = shapely.intersection(
            shapely.linestrings([[(minx - 1.0, y), (maxx + 1.0, y)] for y in ys]), area
        )
        pairs = enumerate(zip(ys, cuts, strict=True))
        return [SweepLine(i, y, _segments(cut)) for i, (y, cut) in pairs]


def _segments(cut: shapely.Geometry) -> tuple[tuple[float, float], ...]:
    spans = []
    for part in shapely.get_parts(cut):
        if part.geom_type != "LineString" or part.length < MIN_SEGMENT_M:
            continue
        xs = [x for x, _ in part.coords]
        spans.append((min(xs), max(xs)))
    spans.sort()
    merged: list[list[float]] = []
    for x0, x1 in spans:  # pieces along an edge can come out split or overlapping
        if merged and x0 <= merged[-1][1] + 1e-9:
            merged[-1][1] = max(merged[-1][1], x1)
        else:
            merged.append([x0, x1])
    return tuple((a, b) for a, b in merged)


@dataclass(frozen=True)
class AngleChooser:
    """The automatic angle: fewest swath segments (turns), then least total swath length.

    Candidates are the directions of the convex hull's edges (the optimum for a convex area is
    parallel to one of them) and every ``step_deg`` degrees.
    """

    step_deg: float = 15.0

    def candidates(self, area: Polygon) -> list[float]:
        hull = list(area.convex_hull.exterior.coords)
        angles = []
        for (x0, y0), (x1, y1) in itertools.pairwise(hull):
            if math.hypot(x1 - x0, y1 - y0) > 1e-6:
                angles.append(round(math.degrees(math.atan2(x1 - x0, y1 - y0)) % 180.0, 6))
        steps = round(180.0 / self.step_deg)
        angles += [k * self.step_deg for k in range(steps)]
        return list(dict.fromkeys(angles))  # hull edges first, no duplicates

    def choose(self, area: Polygon, swaths: SwathGenerator) -> float:
        best: tuple[int, float] | None = None
        best_angle = 0.0
        for angle in self.candidates(area):
            lines = swaths.lines(to_sweep(area, angle))
            segments = sum(len(line.segments) for line in lines)
            length = sum(x1 - x0 for line in lines for x0, x1 in line.segments)
            key = (segments, round(length, 3))
            if best is None or key < best:
                best, best_angle = key, angle
        return best_angle
