"""The coverage pipeline: the Mission Planner's mapping feature (seed 4.2.4, Figure 4.27).

Named stages, each a small object that can be swapped or tested alone (STYLE.md, after
Fields2Cover): project to a local plane → choose the angle → swath lines → boustrophedon cells →
route (back and forth, cell by cell) → path (waypoints, in-area transits, gap spurs) → back to
LLA. ``plan_area(spec)`` runs the default pipeline.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from shapely.geometry import LineString, Point, Polygon

from dronefleet.ground.planner.coverage.angle import AngleChooser
from dronefleet.ground.planner.coverage.decompose import BoustrophedonDecomposer
from dronefleet.ground.planner.coverage.path import GapFiller, PathBuilder, RoutePoint, route_xy
from dronefleet.ground.planner.coverage.plan import CoveragePlan
from dronefleet.ground.planner.coverage.project import LocalProjection
from dronefleet.ground.planner.coverage.route import BoustrophedonOrderer
from dronefleet.ground.planner.coverage.router import InAreaRouter
from dronefleet.ground.planner.coverage.spec import Action, AreaSpec, Grid
from dronefleet.ground.planner.coverage.swaths import (
    SwathGenerator,
    from_sweep_xy,
    to_sweep,
)

#: Most waypoints (or pictures) one area may ask for; a mission holds at most 10 000 steps.
MAX_WAYPOINTS = 20_000
#: Gap tolerance as a fraction of the spacing: a point may be this much beyond half a spacing.
GAP_TOLERANCE = 0.002


@dataclass(frozen=True)
class CoveragePipeline:
    angles: AngleChooser = field(default_factory=AngleChooser)
    decomposer: BoustrophedonDecomposer = field(default_factory=BoustrophedonDecomposer)
    orderer: BoustrophedonOrderer = field(default_factory=BoustrophedonOrderer)
    fill_gaps: bool = True

    def plan(self, spec: AreaSpec) -> CoveragePlan:
        projection = LocalProjection.around(spec)
        area = projection.area(spec)
        spacing = spec.line_spacing_m
        expected = area.area / (spacing * (spec.trigger_m if spec.fly_through else spacing))
        if expected > MAX_WAYPOINTS:
            raise ValueError(
                f"{area.area:.0f} m² at {spacing:g} m spacing needs about {expected:.0f}"
                f" {'pictures' if spec.fly_through else 'waypoints'} (at most {MAX_WAYPOINTS});"
                " widen the spacing or split the area"
            )
        swaths = SwathGenerator(spacing, spec.grid)
        angle = spec.angle_deg if spec.angle_deg is not None else self.angles.choose(area, swaths)
        angle %= 360.0
        sweep_area: Polygon = to_sweep(area, angle)
        lines = swaths.lines(sweep_area)
        cells = self.decomposer.cells(lines)
        if not cells:
            raise ValueError(f"the area is too small for swaths {spacing:g} m apart")
        first = projection.to_xy(*spec.polygon[0])
        start = to_sweep(Point(first), angle).coords[0]
        passes = self.orderer.order(cells, start)
        router = InAreaRouter(sweep_area)
        photo = spec.action == Action.TAKEPIC
        trigger = spec.trigger_m if spec.fly_through else 0.0
        # On the footprint grid, stops that do something are made at the centres of the cells.
        centres = spec.grid == Grid.INSET and spec.action != Action.NONE
        builder = PathBuilder(spacing, spec.fly_through, trigger, photo, centres)
        points = builder.build(passes, router)
        uncovered = 0.0
        if self.fill_gaps:
            filler = GapFiller(spacing / 2.0, GAP_TOLERANCE * spacing, builder)
            points, uncovered = filler.fill(points, sweep_area, router)
        local, xy = _unrotate(points, angle)
        waypoints = projection.to_lla_many(xy, spec.altitude_m)
        return CoveragePlan(
            spec=spec,
            origin=projection.origin,
            angle_deg=angle,
            spacing_m=spacing,
            trigger_distance_m=trigger or None,
            local_polygon=area,
            swaths=[
                LineString([from_sweep_xy(*p.start, angle), from_sweep_xy(*p.end, angle)])
                for p in passes
            ],
            points=local,
            waypoints=waypoints,
            uncovered_m2=uncovered,
            cells=len(cells),
        )


def _unrotate(points: list[RoutePoint], angle: float) -> tuple[list[RoutePoint], np.ndarray]:
    """The route's points back in the local plane, and their coordinates as an array: one
    rotation of them all (:func:`from_sweep_xy` point by point was a tenth of the planning)."""
    a = math.radians(90.0 - angle)
    c, s = math.cos(a), math.sin(a)
    x, y = route_xy(points).T
    xy = np.column_stack((x * c - y * s, x * s + y * c))
    local = [
        RoutePoint(u, v, p.kind, p.trigger_m, p.photos)
        for (u, v), p in zip(xy.tolist(), points, strict=True)
    ]
    return local, xy


def plan_area(spec: AreaSpec) -> CoveragePlan:
    """Plan ``spec`` with the default pipeline."""
    return CoveragePipeline().plan(spec)
