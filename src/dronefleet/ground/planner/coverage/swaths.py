"""Stage 3 of the coverage pipeline: swaths at a spacing and an angle (the automatic angle is
:mod:`.angle`).

Everything here works in the *sweep frame*: the local plane rotated so that the swath bearing
points along +x; swaths are then horizontal lines ``y = offset``, clipped against the area into
segments (a concave area or one with holes gives several segments on one line). The seed's
``step_distance`` is the spacing; its vectors v and w are the grid's axes (Figure 4.28).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely import affinity
from shapely.geometry import Polygon

from dronefleet.ground.planner.coverage.clip import clip, edges_of
from dronefleet.ground.planner.coverage.spec import Grid

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
    #: Lines fewer than the area needs (footprint grid only): the outer strips, each narrower
    #: than half a spacing, are left uncovered; a coverage target below 100 % may allow it.
    fewer: int = 0

    def offsets(self, ymin: float, ymax: float) -> list[float]:
        width, s = ymax - ymin, self.spacing_m
        if self.grid == Grid.INSET:
            # Centred, so that both outer lines are at most half a spacing from the edge.
            n = max(1, math.ceil((width - slack_m(s)) / s) - self.fewer)
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
        _, ymin, _, ymax = area.bounds
        ys = self.offsets(ymin, ymax)
        spans = clip(edges_of(area), np.asarray(ys))
        return [SweepLine(i, y, s) for i, (y, s) in enumerate(zip(ys, spans, strict=True))]
