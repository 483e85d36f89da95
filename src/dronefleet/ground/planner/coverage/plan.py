"""The coverage pipeline's output: waypoints, geometry, and the mission steps that fly them.

One waypoint is one *unit* of the mission (a ``navigate`` and the steps after it, see
:mod:`dronefleet.ground.planner.units`), so ``waypoints[i]`` is unit ``i`` of
:meth:`CoveragePlan.mission_steps` and allocation indices address both.

Stopping surveys: ``navigate`` + ``wait_for_flight`` + the action at each waypoint (the seed's
``intermediate_action``). Fly-through surveys, per swath: ``navigate`` to its start,
``wait_for_flight`` (0.5 m), ``camera_trigger d``; ``navigate`` to its end, ``wait_for_flight``
(0.5 m), ``camera_trigger 0``. The trigger is off across turns so that no picture falls outside a
swath, and ``d`` is the planned trigger distance shortened so that a whole number of intervals
ends 2 m before the swath end: each swath gets exactly its planned pictures (the first where the
trigger is set, the last just before the end), whatever the polling jitter.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from shapely.geometry import LineString, Polygon

from dronefleet.geo.types import LLA
from dronefleet.ground.planner.coverage.path import END_TOLERANCE_M, Kind, RoutePoint
from dronefleet.ground.planner.coverage.spec import Action, AreaSpec

#: Time the planner allows for a picture taken while stopped (gear round trip), seconds.
PICTURE_S = 0.1


@dataclass
class CoveragePlan:
    """An area turned into a route. ``waypoints`` are LLA with ``alt_m`` = height above home."""

    spec: AreaSpec
    origin: LLA  # the local plane's origin (x east, y north, metres)
    angle_deg: float  # swath bearing, degrees clockwise from north (rings: none, 90)
    spacing_m: float
    trigger_distance_m: float | None  # fly-through only
    local_polygon: Polygon
    swaths: list[LineString]  # flown passes, in route order, local plane
    points: list[RoutePoint]  # route points, local plane
    waypoints: list[LLA]
    uncovered_m2: float = 0.0  # area farther than half a spacing from the path
    cells: int = 1
    extras: dict[str, Any] = field(default_factory=dict)
    uncovered: list[Polygon] = field(default_factory=list)  # those pieces, local plane
    uncovered_rings: list[list[tuple[float, float]]] = field(default_factory=list)  # [lat, lon]
    pattern: str = "swaths"  # or "rings" (contour.py) or "headland" (headland.py)

    @property
    def coverage_pct(self) -> float:
        """Share of the area within half a spacing of the path (100 less what is left)."""
        return 100.0 * (1.0 - self.uncovered_m2 / self.area_m2) if self.area_m2 > 0 else 100.0

    @property
    def altitude_m(self) -> float:
        return self.spec.altitude_m

    @property
    def area_m2(self) -> float:
        return float(self.local_polygon.area)

    @property
    def kinds(self) -> list[Kind]:
        return [p.kind for p in self.points]

    @property
    def photo_count(self) -> int:
        """Pictures the mission should take (stopped and distance-triggered)."""
        return sum(p.photos for p in self.points)

    @property
    def local_path(self) -> LineString:
        xy = [p.xy for p in self.points]
        return LineString(xy if len(xy) > 1 else xy * 2)

    @property
    def path_length_m(self) -> float:
        return float(self.local_path.length)

    def holds_s(self) -> list[float]:
        """Seconds spent stopped at each waypoint by its action (for allocation)."""
        hold = {Action.NONE: 0.0, Action.TAKEPIC: PICTURE_S, Action.READ_SENSORS: 0.0}
        hold[Action.READ_SENSORS] = self.spec.hold_s
        return [hold[self.spec.action] if k is Kind.WORK else 0.0 for k in self.kinds]

    def chunk_starts(self) -> list[bool]:
        """Where a drone's share may begin: not in the middle of a fly-through swath."""
        return [k is not Kind.SWATH_END for k in self.kinds]

    def _action(self) -> list[dict[str, Any]]:
        if self.spec.action == Action.TAKEPIC:
            return [{"command": "takepic"}]
        if self.spec.action == Action.READ_SENSORS:
            return [{"command": "read_sensors", "value": self.spec.hold_s}]
        return []

    def unit_steps(self, index: int, *, altitude_offset_m: float = 0.0) -> list[dict[str, Any]]:
        """The steps of waypoint ``index``: its ``navigate`` and what follows it."""
        p, wp = self.points[index], self.waypoints[index]
        altitude = round(self.spec.altitude_m + altitude_offset_m, 3)
        nav = {"command": "navigate", "lat": wp.lat, "lon": wp.lon, "altitude_delta": altitude}
        kind = p.kind
        if kind is Kind.WORK:
            return [nav, {"command": "wait_for_flight"}, *self._action()]
        if kind is Kind.TRANSIT:
            return [nav, {"command": "wait_for_flight"}]
        wait = {"command": "wait_for_flight", "horizontal_tolerance_m": END_TOLERANCE_M}
        trigger = round(p.trigger_m, 4) if kind is Kind.SWATH_START else 0
        return [nav, wait, {"command": "camera_trigger", "value": trigger}]

    def mission_steps(
        self, indices: list[int] | range | None = None, *, altitude_offset_m: float = 0.0
    ) -> list[dict[str, Any]]:
        """Mission steps for the waypoints ``indices`` (default all), one unit per waypoint."""
        chosen = range(len(self.points)) if indices is None else indices
        steps: list[dict[str, Any]] = []
        for i in chosen:
            steps += self.unit_steps(i, altitude_offset_m=altitude_offset_m)
        return steps

    def steps(self, altitude_offset_m: float = 0.0) -> list[dict[str, Any]]:
        """All the mission steps (alias of :meth:`mission_steps`)."""
        return self.mission_steps(altitude_offset_m=altitude_offset_m)

    def summary(self) -> dict[str, Any]:
        return {
            "waypoints": len(self.waypoints),
            "photos": self.photo_count,
            "angle_deg": round(self.angle_deg, 3) if self.pattern == "swaths" else None,
            "pattern": self.pattern,
            "spacing_m": self.spacing_m,
            "trigger_distance_m": self.trigger_distance_m,
            "area_m2": round(self.area_m2, 1),
            "path_length_m": round(self.path_length_m, 1),
            "swaths": len(self.swaths),
            "cells": self.cells,
            "uncovered_m2": round(self.uncovered_m2, 3),
            "coverage_pct": round(self.coverage_pct, 3),
            "coverage_target_pct": self.spec.coverage_target_pct,
            "uncovered": [[[round(a, 7), round(b, 7)] for a, b in r] for r in self.uncovered_rings],
        }
