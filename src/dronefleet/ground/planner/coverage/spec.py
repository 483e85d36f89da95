"""What an area task asks for: the Mission Planner's mapping input (seed 4.2.4, Figure 4.27).

An :class:`AreaSpec` travels over REST and is stored with the mission, so it is also the seed's
*extensibility parameters* (Figure 4.28) generalised: from it the planner rebuilds the same task
with a new centre and a larger area (:mod:`.extend`). The polygon is ``[lat, lon]`` pairs (the
seed's three clicked vertices become a parallelogram via :meth:`AreaSpec.parallelogram`; GeoJSON,
whose pairs are ``[lon, lat]``, via :meth:`AreaSpec.from_geojson`).

Spacing is given directly or derived from a camera the way QGroundControl's survey does it: the
ground footprint at the flight height, less the side overlap across track (line spacing) and the
front overlap along track (trigger distance).
"""

from __future__ import annotations

import json
from enum import StrEnum
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from dronefleet.geo.ned import LocalFrame
from dronefleet.geo.types import LLA, NED
from dronefleet.messaging.commands import MAX_ALTITUDE_M

LatLon = tuple[float, float]
#: Most vertices a ring may have (transits route over the corners: cost grows as their square).
MAX_VERTICES = 2000
#: The lowest coverage target an operator may set (percent of the area).
MIN_TARGET_PCT = 50.0


class Action(StrEnum):
    """The seed's ``intermediate_action``: what to do at each waypoint."""

    NONE = "none"
    TAKEPIC = "takepic"
    READ_SENSORS = "read_sensors"


class Grid(StrEnum):
    """Where the first swath lies."""

    #: Half a spacing inside the edge: each swath covers a strip of one spacing (footprint tiling).
    INSET = "inset"
    #: On the edges, as the seed's grid (5.2: 32 x 64 m at 8 m -> 5 x 9 = 45 waypoints).
    SEED = "seed"


class CameraSpec(BaseModel):
    """A nadir camera; the image's width lies across the flight line (landscape)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    sensor_width_mm: float = Field(gt=0, le=100)
    sensor_height_mm: float = Field(gt=0, le=100)
    focal_length_mm: float = Field(gt=0, le=1000)
    image_width_px: int = Field(gt=0)
    image_height_px: int = Field(gt=0)
    front_overlap: float = Field(default=0.7, ge=0, lt=1)
    side_overlap: float = Field(default=0.6, ge=0, lt=1)

    def footprint_m(self, altitude_m: float) -> tuple[float, float]:
        """Ground footprint (across track, along track) of one picture at ``altitude_m``."""
        k = altitude_m / self.focal_length_mm
        return self.sensor_width_mm * k, self.sensor_height_mm * k

    def line_spacing_m(self, altitude_m: float) -> float:
        return self.footprint_m(altitude_m)[0] * (1.0 - self.side_overlap)

    def trigger_distance_m(self, altitude_m: float) -> float:
        return self.footprint_m(altitude_m)[1] * (1.0 - self.front_overlap)

    def gsd_cm_per_px(self, altitude_m: float) -> float:
        """Ground sampling distance (cm per pixel) at ``altitude_m``."""
        return 100.0 * self.footprint_m(altitude_m)[0] / self.image_width_px


def _ring(points: list[LatLon], what: str) -> list[LatLon]:
    ring = [(float(lat), float(lon)) for lat, lon in points]
    if len(ring) > MAX_VERTICES:
        raise ValueError(f"{what} has {len(ring)} vertices; at most {MAX_VERTICES}")
    if len(ring) > 1 and ring[0] == ring[-1]:
        ring = ring[:-1]
    if len(ring) < 3:
        raise ValueError(f"{what} needs at least 3 distinct vertices, got {len(ring)}")
    for lat, lon in ring:
        if not (-90 <= lat <= 90 and -180 <= lon <= 180):
            raise ValueError(f"{what} vertex [{lat}, {lon}] is not a [lat, lon] pair in range")
    return ring


class AreaSpec(BaseModel):
    """An area to cover: polygon (+ holes), spacing or camera, height, angle, action, mode."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    polygon: list[LatLon] = Field(max_length=MAX_VERTICES, description="exterior, [lat, lon]s")
    holes: list[list[LatLon]] = Field(
        default_factory=list, max_length=100, description="rings to keep out of"
    )
    spacing_m: float | None = Field(default=None, gt=0, le=1000, description="line spacing")
    camera: CameraSpec | None = None
    altitude_m: float = Field(default=10.0, gt=0, le=MAX_ALTITUDE_M, description="above home")
    angle_deg: float | None = Field(
        default=None, description="swath bearing, degrees from north; None: fewest swaths"
    )
    action: Action = Action.NONE
    hold_s: float = Field(default=2.0, ge=0, le=3600, description="read_sensors hold")
    fly_through: bool = Field(default=False, description="photograph without stopping")
    grid: Grid = Grid.INSET
    trigger_distance_m: float | None = Field(default=None, gt=0, le=1000)
    coverage_target_pct: float = Field(
        default=100.0,
        description="share of the area to cover (50-100); below 100 slivers narrower than a"
        " spacing may be left, up to the rest",
        # Published as the schema's bounds; checked by _target, whose refusal says what it is.
        json_schema_extra={"minimum": MIN_TARGET_PCT, "maximum": 100.0},
    )

    @field_validator("coverage_target_pct")
    @classmethod
    def _target(cls, value: float) -> float:
        if not MIN_TARGET_PCT <= value <= 100.0:
            raise ValueError(
                f"coverage_target_pct must be between {MIN_TARGET_PCT:g} and 100 (percent of"
                f" the area to cover), got {value:g}"
            )
        return float(value)

    @field_validator("polygon")
    @classmethod
    def _exterior(cls, value: list[LatLon]) -> list[LatLon]:
        return _ring(value, "polygon")

    @field_validator("holes")
    @classmethod
    def _holes(cls, value: list[list[LatLon]]) -> list[list[LatLon]]:
        return [_ring(hole, f"hole {i}") for i, hole in enumerate(value)]

    @model_validator(mode="after")
    def _consistent(self) -> AreaSpec:
        if (self.spacing_m is None) == (self.camera is None):
            raise ValueError("give exactly one of spacing_m or camera")
        if self.fly_through and self.action != Action.TAKEPIC:
            raise ValueError("fly_through photographs on the move: it needs action 'takepic'")
        return self

    # -- derived ------------------------------------------------------------------------------
    @property
    def line_spacing_m(self) -> float:
        if self.spacing_m is not None:
            return self.spacing_m
        assert self.camera is not None
        return self.camera.line_spacing_m(self.altitude_m)

    @property
    def trigger_m(self) -> float:
        """Distance between pictures along a swath (fly-through), default the line spacing."""
        if self.trigger_distance_m is not None:
            return self.trigger_distance_m
        if self.camera is not None:
            return self.camera.trigger_distance_m(self.altitude_m)
        return self.line_spacing_m

    # -- constructors -------------------------------------------------------------------------
    @classmethod
    def parallelogram(
        cls, p1: LLA | LatLon, p2: LLA | LatLon, p3: LLA | LatLon, **fields: Any
    ) -> AreaSpec:
        """The seed's three clicked vertices (5.2.2): the fourth is p1 + p3 - p2 (local plane)."""
        a, b, c = (p if isinstance(p, LLA) else LLA(p[0], p[1]) for p in (p1, p2, p3))
        frame = LocalFrame(LLA(b.lat, b.lon))
        v, w = frame.to_ned(LLA(a.lat, a.lon)), frame.to_ned(LLA(c.lat, c.lon))
        d = frame.to_lla(NED(v.n + w.n, v.e + w.e))
        ring = [(a.lat, a.lon), (b.lat, b.lon), (c.lat, c.lon), (d.lat, d.lon)]
        return cls(polygon=ring, **fields)

    @classmethod
    def from_geojson(cls, geojson: dict[str, Any] | str, **fields: Any) -> AreaSpec:
        """From a GeoJSON Polygon (or a Feature holding one); coordinates are [lon, lat]."""
        data = json.loads(geojson) if isinstance(geojson, str) else geojson
        if data.get("type") == "Feature":
            data = data.get("geometry") or {}
        if data.get("type") != "Polygon":
            raise ValueError(f"expected a GeoJSON Polygon, got {data.get('type')!r}")
        rings = data.get("coordinates") or []
        if not rings:
            raise ValueError("the GeoJSON Polygon has no rings")
        swap = [[(pt[1], pt[0]) for pt in ring] for ring in rings]
        return cls(polygon=swap[0], holes=swap[1:], **fields)

    def to_geojson(self) -> dict[str, Any]:
        """The area as a GeoJSON Polygon ([lon, lat], rings closed)."""
        rings = [self.polygon, *self.holes]
        return {
            "type": "Polygon",
            "coordinates": [[[lon, lat] for lat, lon in (*r, r[0])] for r in rings],
        }
