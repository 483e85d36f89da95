"""A geofence and rally points as missions carry them: where a drone may fly, and where it may
come down instead of home (issue 14).

An inclusion polygon (the site: fly inside it), exclusion polygons (a road, a house: never over
them) and a ceiling above home, as ArduPilot's polygon fences and FENCE_ALT_MAX are. The ground
checks every share against it before a mission is accepted (ground/planner/geofence.py) and sends
it with each leg; the drone watches its position against it in flight (drone/fence_guard.py).

Rally points are ArduPilot's (MAV_CMD_NAV_RALLY_POINT): places to land that are not home. A drone
sent home early (abort, a handover, a lost drone heard again) goes to the nearest one when it is
nearer than home (ground/planner/rally.py); a MAVLink autopilot gets them too
(drone/autopilot_fence.py), so that its own RTL and failsafes use them.

Geometry with shapely (already the coverage planner's), in a local metric frame (north, east
metres from the first fence corner, or from the drone when there is no inclusion polygon): over a
site a few kilometres wide straight lines in it differ from great circles by centimetres.
"""

from __future__ import annotations

from pydantic import ConfigDict, Field, field_validator
from shapely.geometry import LineString, Point, Polygon

from dronefleet.geo.distance import distance_m
from dronefleet.geo.ned import lla_to_ned
from dronefleet.geo.types import LLA
from dronefleet.messaging.common import Message

LatLonList = list[list[float]]


class Geofence(Message):
    """Inclusion polygon, exclusion polygons ([lat, lon] corners) and a ceiling (m above home)."""

    model_config = ConfigDict(extra="forbid")

    inclusion: LatLonList | None = Field(default=None, max_length=1000)
    exclusions: list[LatLonList] = Field(default_factory=list, max_length=100)
    ceiling_m: float | None = Field(default=None, gt=0, le=10_000)

    @field_validator("inclusion")
    @classmethod
    def _inclusion(cls, value: LatLonList | None) -> LatLonList | None:
        if value is not None:
            _check_polygon(value)
        return value

    @field_validator("exclusions")
    @classmethod
    def _exclusions(cls, value: list[LatLonList]) -> list[LatLonList]:
        for shape in value:
            _check_polygon(shape)
        return value


class RallyPoint(Message):
    """A place to land that is not home: [lat, lon] and the height (m above home) to fly there
    at, as QGroundControl's rally points and ArduPilot's RALLY_POINT are."""

    model_config = ConfigDict(extra="forbid")

    lat: float = Field(ge=-90, le=90)
    lon: float = Field(ge=-180, le=180)
    alt_m: float = Field(default=15.0, gt=0, le=1000, description="height above home to fly at")


#: Most rally points a mission may carry (ArduPilot keeps up to RALLY_TOTAL, 6 by default on
#: small boards; QGroundControl draws any number).
MAX_RALLY_POINTS = 100


def _check_polygon(shape: LatLonList) -> None:
    if not 3 <= len(shape) <= 1000:
        raise ValueError("a fence polygon has 3 to 1000 [lat, lon] corners")
    for corner in shape:
        if len(corner) != 2 or not (-90 <= corner[0] <= 90 and -180 <= corner[1] <= 180):
            raise ValueError(f"a fence corner is [lat, lon] in degrees, not {corner}")


class FenceShape:
    """A fence's polygons in a local metric frame, for point and straight-leg checks."""

    def __init__(self, fence: Geofence, near: LLA) -> None:
        self.fence = fence
        corner = fence.inclusion[0] if fence.inclusion else None
        self.origin = LLA(corner[0], corner[1], 0.0) if corner else LLA(near.lat, near.lon, 0.0)
        self.inside = self._polygon(fence.inclusion) if fence.inclusion else None
        self.keep_out = [self._polygon(p) for p in fence.exclusions]

    def breach(self, here: LLA, home: LLA, margin_m: float = 0.0) -> str | None:
        """Why ``here`` is not allowed (``margin_m`` forgiven), or None."""
        height = here.alt_m - home.alt_m
        ceiling = self.fence.ceiling_m
        if ceiling is not None and height > ceiling + margin_m + 1e-6:
            return f"{height:.0f} m up, above the fence ceiling of {ceiling:g} m"
        point = Point(*self.xy(here))
        inside = self.inside
        if inside is not None and _beyond(inside, point, margin_m):
            return "outside the inclusion fence"
        for k, zone in enumerate(self.keep_out):
            if zone.contains(point) and zone.exterior.distance(point) > margin_m:
                return f"inside exclusion zone {k + 1}"
        return None

    def leg_breach(self, a: LLA, b: LLA) -> str | None:
        """Why the straight leg from ``a`` to ``b`` is not allowed, or None."""
        line = LineString([self.xy(a), self.xy(b)])
        if self.inside is not None and not self.inside.covers(line):
            return "leaves the inclusion fence"
        for k, zone in enumerate(self.keep_out):
            if line.intersects(zone):
                return f"crosses exclusion zone {k + 1}"
        return None

    def xy(self, p: LLA) -> tuple[float, float]:
        ned = lla_to_ned(LLA(p.lat, p.lon, self.origin.alt_m), self.origin)
        return (ned.e, ned.n)

    def _polygon(self, corners: LatLonList) -> Polygon:
        shape = Polygon([self.xy(LLA(lat, lon, 0.0)) for lat, lon in corners])
        return shape if shape.is_valid else shape.buffer(0)  # a self-touching outline, repaired


def _beyond(zone: Polygon, point: Point, margin_m: float) -> bool:
    """Outside ``zone`` by more than ``margin_m``."""
    return not zone.contains(point) and zone.exterior.distance(point) > margin_m


def nearest_rally(
    points: list[RallyPoint], here: LLA, home: LLA, fence: Geofence | None = None
) -> RallyPoint | None:
    """Where a drone at ``here`` sent home early lands instead: the nearest rally point that is
    nearer than ``home`` and reached by a straight leg inside ``fence``; None: home it is.

    ArduPilot's RTL chooses the same way among its rally points and home (RALLY_INCL_HOME 1).
    """
    shape = FenceShape(fence, here) if fence is not None else None
    best, best_m = None, distance_m(here, home)
    for point in points:
        there = LLA(point.lat, point.lon, home.alt_m + point.alt_m)
        metres = distance_m(here, there)
        if metres >= best_m or (shape is not None and shape.leg_breach(here, there)):
            continue
        best, best_m = point, metres
    return best
