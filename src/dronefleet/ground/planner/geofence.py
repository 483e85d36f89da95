"""Geofence: where a mission may fly, checked before it is accepted (issue 14).

A fence is an inclusion polygon (the site: fly inside it), exclusion polygons (a road, a house:
never over them) and a ceiling above home, as ArduPilot's polygon fences and FENCE_ALT_MAX are.
Each drone's share is checked as it would fly: from where the drone is, through every
``navigate`` of its preparation, work and end, back home when its end is a return (RTL flies
straight home). Every point must be inside the inclusion polygon and at or under the ceiling;
every straight leg between two points inside the inclusion polygon and clear of every exclusion.
A share that is not is refused with the drone, the step and where (REST 422); nothing changes.

Geometry with shapely (already the coverage planner's), in a local metric frame (north, east
metres from the first fence point): a few degrees of latitude make straight lines in it differ
from great circles by centimetres, well under any fence margin.
"""

from __future__ import annotations

import itertools
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, field_validator
from shapely.geometry import LineString, Point, Polygon

from dronefleet.errors import InvalidInput
from dronefleet.geo.ned import lla_to_ned
from dronefleet.geo.types import LLA
from dronefleet.messaging.commands import Command

LatLonList = list[list[float]]


class Geofence(BaseModel):
    """Inclusion polygon, exclusion polygons ([lat, lon] corners) and a ceiling (m above home)."""

    model_config = ConfigDict(extra="forbid")

    inclusion: LatLonList | None = Field(default=None, max_length=1000)
    exclusions: list[LatLonList] = Field(default_factory=list, max_length=100)
    ceiling_m: float | None = Field(default=None, gt=0, le=10_000)

    @field_validator("inclusion", "exclusions")
    @classmethod
    def _polygons(cls, value: Any) -> Any:
        shapes = [value] if value and isinstance(value[0][0], int | float) else value or []
        for shape in shapes:
            if len(shape) < 3 or len(shape) > 1000:
                raise ValueError("a fence polygon has 3 to 1000 [lat, lon] corners")
            for corner in shape:
                if len(corner) != 2 or not (-90 <= corner[0] <= 90 and -180 <= corner[1] <= 180):
                    raise ValueError(f"a fence corner is [lat, lon] in degrees, not {corner}")
        return value


class FenceBreach(InvalidInput, ValueError):
    """A share that would leave the fence: the message says which drone, step and where."""


def check_share(
    fence: Geofence,
    drone_id: str,
    start: LLA,
    home: LLA,
    steps: list[dict[str, Any]],
    returns_home: bool,
) -> None:
    """Raise :class:`FenceBreach` when ``drone_id`` flying ``steps`` from ``start`` would leave
    ``fence`` (``returns_home``: its end flies straight home afterwards)."""
    origin = _origin(fence, start)
    inside = _polygon(fence.inclusion, origin) if fence.inclusion else None
    keep_out = [_polygon(p, origin) for p in fence.exclusions]
    path: list[tuple[str, LLA]] = [("where it starts", start)]
    for i, step in enumerate(steps):
        if step.get("command") == Command.NAVIGATE:
            height = step.get("altitude_delta")
            alt = home.alt_m + height if isinstance(height, int | float) else path[-1][1].alt_m
            path.append((f"step {i} (navigate)", LLA(step["lat"], step["lon"], alt)))
        elif step.get("command") == Command.TAKEOFF and _above(step.get("value"), fence):
            raise FenceBreach(
                f"fence: {drone_id} step {i} takes off to {step['value']:g} m, above the "
                f"fence ceiling of {fence.ceiling_m:g} m"
            )
    if returns_home:
        path.append(("its way home", home))
    for what, here in path:
        if fence.ceiling_m is not None and here.alt_m - home.alt_m > fence.ceiling_m + 1e-6:
            raise FenceBreach(
                f"fence: {drone_id} {what} at {here.lat:.6f}, {here.lon:.6f} flies "
                f"{here.alt_m - home.alt_m:.0f} m up, above the fence ceiling of "
                f"{fence.ceiling_m:g} m"
            )
        if inside is not None and not inside.covers(Point(*_xy(here, origin))):
            raise FenceBreach(
                f"fence: {drone_id} {what} at {here.lat:.6f}, {here.lon:.6f} is outside the "
                "inclusion fence"
            )
    for (came, a), (went, b) in itertools.pairwise(path):
        line = LineString([_xy(a, origin), _xy(b, origin)])
        if inside is not None and not inside.covers(line):
            raise FenceBreach(
                f"fence: {drone_id} flying from {came} to {went} leaves the inclusion fence"
            )
        for k, zone in enumerate(keep_out):
            if line.intersects(zone):
                raise FenceBreach(
                    f"fence: {drone_id} flying from {came} to {went} crosses exclusion zone {k + 1}"
                )


def _above(height: Any, fence: Geofence) -> bool:
    return fence.ceiling_m is not None and float(height or 0.0) > fence.ceiling_m


def _origin(fence: Geofence, start: LLA) -> LLA:
    corner = fence.inclusion[0] if fence.inclusion else None
    return LLA(corner[0], corner[1], 0.0) if corner else LLA(start.lat, start.lon, 0.0)


def _xy(p: LLA, origin: LLA) -> tuple[float, float]:
    ned = lla_to_ned(LLA(p.lat, p.lon, origin.alt_m), origin)
    return (ned.e, ned.n)


def _polygon(corners: LatLonList, origin: LLA) -> Polygon:
    shape = Polygon([_xy(LLA(lat, lon, 0.0), origin) for lat, lon in corners])
    return shape if shape.is_valid else shape.buffer(0)  # a self-touching outline, repaired
