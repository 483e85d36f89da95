"""QGroundControl ``.plan`` files read into a mission request (issue 14).

The format is QGroundControl's own (its "Plan File Format" page): a JSON object with
``"fileType": "Plan"``, ``"version": 1``, ``mission`` (``items``: ``SimpleItem`` s, each a MAVLink
command with its frame and seven params, and ``ComplexItem`` s such as a survey, plus the
``plannedHomePosition``), ``geoFence`` (inclusion/exclusion polygons and circles) and
``rallyPoints`` (``[lat, lon, alt]``). No kept Python library reads it (MAVSDK's importer runs in
its ``mavsdk_server`` and gives raw MAVLink items, not a planner's input), so it is read here with
pydantic models of exactly the fields used; every other key is ignored, as QGroundControl does.

How items become the seed's steps (Table 4.3):

- NAV_WAYPOINT: ``navigate`` + ``wait_for_flight`` (its hold time a ``sleep``); NAV_TAKEOFF:
  ``arm``, ``takeoff``, ``wait_for_flight``; NAV_LAND: (``navigate`` there), ``land``;
  NAV_RETURN_TO_LAUNCH: ``rtl``; NAV_LOITER_TIME and NAV_DELAY: a ``sleep`` (where it is);
  DO_DIGICAM_CONTROL and a one-picture IMAGE_START_CAPTURE: ``takepic``; DO_SET_CAM_TRIGG_DIST:
  ``camera_trigger``.
- Altitudes are heights above home: relative frames as they are, absolute (AMSL) frames less the
  planned home's altitude; terrain frames are flown above home, with a warning.
- Other DO and condition commands (speed, ROI, gimbal...) are left out with a warning; NAV
  commands dronefleet cannot fly (loiter forever, DO_JUMP...) refuse the file.
- A survey alone (with at most a take-off, a landing or a return around it) becomes the planner's
  area (polygon, angle, line spacing and height from its CameraCalc, photos by distance), so the
  planner can share it among drones; beside other waypoints, its generated items are flown as
  steps.
- The fence: one inclusion zone (polygon, or circle drawn as a 36-sided polygon inside it),
  exclusion polygons and circles (circles as 36-sided polygons around them); the ceiling is not
  in QGroundControl's format and is read from our own ``dronefleet.fence_ceiling_m`` key.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

import orjson
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from dronefleet.geo.distance import offset
from dronefleet.geo.types import LLA
from dronefleet.ground.planner.files.imported import (
    FileKind,
    ImportedMission,
    MissionFileError,
    mission_spec,
)
from dronefleet.messaging.common import reason
from dronefleet.protocols.mavlink.codec import dialect as mav

#: Sides of the polygon a fence circle becomes.
CIRCLE_SIDES = 36
#: Line spacing (m) of a survey whose CameraCalc does not give one (the planner page's default).
DEFAULT_SPACING_M = 10.0
MAX_ITEMS = 10_000

RELATIVE_FRAMES = {mav.MAV_FRAME_GLOBAL_RELATIVE_ALT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT}
ABSOLUTE_FRAMES = {mav.MAV_FRAME_GLOBAL, mav.MAV_FRAME_GLOBAL_INT}
TERRAIN_FRAMES = {mav.MAV_FRAME_GLOBAL_TERRAIN_ALT, mav.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT}
#: What a survey may have around it and still be imported as an area.
_AROUND_A_SURVEY = {mav.MAV_CMD_NAV_TAKEOFF, mav.MAV_CMD_NAV_LAND, mav.MAV_CMD_NAV_RETURN_TO_LAUNCH}
#: Commands that change the route in a way the steps cannot say.
_UNFLYABLE = {mav.MAV_CMD_DO_JUMP, mav.MAV_CMD_DO_LAND_START}


class _Loose(BaseModel):
    """A part of the file: the fields used are checked, any other key is ignored."""

    model_config = ConfigDict(extra="ignore", allow_inf_nan=False)


LatLon = tuple[Annotated[float, Field(ge=-90, le=90)], Annotated[float, Field(ge=-180, le=180)]]


class SimpleItem(_Loose):
    type: Literal["SimpleItem"]
    command: int = Field(ge=0, le=65535)
    frame: int = Field(default=mav.MAV_FRAME_GLOBAL_RELATIVE_ALT, ge=0, le=255)
    params: list[float | None] = Field(min_length=7, max_length=7)  # QGC writes NaN as null
    autoContinue: bool = True


class Camera(_Loose):
    """A survey's ``CameraCalc``: what its footprint and height came to."""

    AdjustedFootprintSide: float | None = None  # line spacing (m)
    AdjustedFootprintFrontal: float | None = None  # distance between pictures (m)
    DistanceToSurface: float | None = None  # flight height (m)


class Transects(_Loose):
    Items: list[SimpleItem] = Field(default_factory=list, max_length=MAX_ITEMS)
    CameraCalc: Camera | None = None


class ComplexItem(_Loose):
    type: Literal["ComplexItem"]
    complexItemType: str = Field(max_length=64)
    polygon: list[LatLon] | None = Field(default=None, max_length=2000)
    angle: float | None = None
    TransectStyleComplexItem: Transects | None = None
    CameraCalc: Camera | None = None  # surveys before version 4 keep it here

    @property
    def items(self) -> list[SimpleItem]:
        return self.TransectStyleComplexItem.Items if self.TransectStyleComplexItem else []

    @property
    def camera(self) -> Camera | None:
        transects = self.TransectStyleComplexItem
        return (transects.CameraCalc if transects else None) or self.CameraCalc


Item = Annotated[SimpleItem | ComplexItem, Field(discriminator="type")]


class PlanMission(_Loose):
    items: list[Item] = Field(default_factory=list, max_length=MAX_ITEMS)
    plannedHomePosition: list[float | None] | None = Field(default=None, max_length=3)


class FencePolygon(_Loose):
    inclusion: bool = True
    polygon: list[LatLon] = Field(max_length=1000)


class Circle(_Loose):
    center: LatLon
    radius: float = Field(gt=0, le=100_000)


class FenceCircle(_Loose):
    inclusion: bool = True
    circle: Circle


class PlanFence(_Loose):
    polygons: list[FencePolygon] = Field(default_factory=list, max_length=100)
    circles: list[FenceCircle] = Field(default_factory=list, max_length=100)


class PlanRally(_Loose):
    points: list[list[float | None]] = Field(default_factory=list, max_length=100)


class Extras(_Loose):
    """What dronefleet adds to the files it writes (QGroundControl ignores the key)."""

    fence_ceiling_m: float | None = None


class PlanFile(_Loose):
    fileType: Literal["Plan"]
    version: Literal[1]
    groundStation: str | None = Field(default=None, max_length=200)
    mission: PlanMission = Field(default_factory=PlanMission)
    geoFence: PlanFence = Field(default_factory=PlanFence)
    rallyPoints: PlanRally = Field(default_factory=PlanRally)
    dronefleet: Extras | None = None


def read_plan(data: bytes, name: str = "") -> ImportedMission:
    """The mission request a .plan file says; :class:`MissionFileError` with why not."""
    try:
        raw = orjson.loads(data)
    except orjson.JSONDecodeError as exc:
        raise MissionFileError(f".plan: not JSON ({exc})") from None
    if not isinstance(raw, dict) or raw.get("fileType") != "Plan":
        raise MissionFileError('.plan: not a QGroundControl plan (no "fileType": "Plan")')
    try:
        plan = PlanFile.model_validate(raw)
    except ValidationError as exc:
        raise MissionFileError(f".plan: {reason(exc)}") from None
    home = _home(plan.mission.plannedHomePosition)
    warnings: list[str] = []
    body: dict[str, Any] = {"name": name or "imported .plan"}
    body.update(_Items(home, warnings).read(plan.mission.items))
    options: dict[str, Any] = {}
    fence = _fence(plan, warnings)
    if fence:
        options["geofence"] = fence
    rally = _rally(plan.rallyPoints, warnings)
    if rally:
        options["rally_points"] = rally
    if options:
        body["options"] = options
    return ImportedMission(
        kind=FileKind.PLAN,
        spec=mission_spec(body, ".plan"),
        home=[home.lat, home.lon, home.alt_m] if home else None,
        warnings=warnings,
    )


def _home(position: list[float | None] | None) -> LLA | None:
    if not position or len(position) < 2 or position[0] is None or position[1] is None:
        return None
    lat, lon = position[0], position[1]
    if not (-90 <= lat <= 90 and -180 <= lon <= 180):
        raise MissionFileError(f".plan: plannedHomePosition {position} is not [lat, lon, alt]")
    alt = position[2] if len(position) > 2 and position[2] is not None else 0.0
    return LLA(lat, lon, alt)


def _command_name(command: int) -> str:
    entry = mav.enums["MAV_CMD"].get(command)
    return entry.name if entry is not None else f"command {command}"


class _Items:
    """Mission items turned into steps, in order."""

    def __init__(self, home: LLA | None, warnings: list[str]) -> None:
        self.home, self.warnings = home, warnings
        self.steps: list[dict[str, Any]] = []

    def read(self, items: list[SimpleItem | ComplexItem]) -> dict[str, Any]:
        """``{"steps": [...]}``, or ``{"area": {...}}`` for a survey alone."""
        surveys = [i for i in items if isinstance(i, ComplexItem) and i.complexItemType == "survey"]
        others = [i for i in items if isinstance(i, SimpleItem) and _is_nav(i.command)]
        if len(surveys) == 1 and all(i.command in _AROUND_A_SURVEY for i in others):
            return {"area": self._area(surveys[0])}
        for k, item in enumerate(items):
            if isinstance(item, SimpleItem):
                self.simple(f"mission item {k + 1}", item)
                continue
            if not item.items:
                raise MissionFileError(
                    f".plan: mission item {k + 1} ({item.complexItemType}) has no items to fly"
                )
            for j, inner in enumerate(item.items):
                self.simple(f"mission item {k + 1} ({item.complexItemType}) item {j + 1}", inner)
        if not self.steps:
            raise MissionFileError(".plan: the mission has no item dronefleet can fly")
        return {"steps": self.steps}

    def _area(self, survey: ComplexItem) -> dict[str, Any]:
        if not survey.polygon:
            raise MissionFileError(".plan: the survey has no polygon")
        camera = survey.camera or Camera()
        height = camera.DistanceToSurface or next(
            (i.params[6] for i in survey.items if i.command == mav.MAV_CMD_NAV_WAYPOINT), None
        )
        spacing = camera.AdjustedFootprintSide
        if not spacing or spacing <= 0:
            spacing = DEFAULT_SPACING_M
            self.warnings.append(f"survey: no line spacing in the file; {spacing:g} m used")
        area: dict[str, Any] = {
            "polygon": [list(p) for p in survey.polygon],
            "spacing_m": spacing,
            "altitude_m": height if height and height > 0 else 15.0,
        }
        if survey.angle is not None:
            area["angle_deg"] = survey.angle
        triggers = any(
            i.command == mav.MAV_CMD_DO_SET_CAM_TRIGG_DIST and (i.params[0] or 0) > 0
            for i in survey.items
        )
        if triggers and camera.AdjustedFootprintFrontal and camera.AdjustedFootprintFrontal > 0:
            area.update(
                action="takepic", fly_through=True,
                trigger_distance_m=camera.AdjustedFootprintFrontal,
            )  # fmt: skip
        return area

    # -- one item -------------------------------------------------------------------------------
    def simple(self, where: str, item: SimpleItem) -> None:
        p, command = item.params, item.command
        if command == mav.MAV_CMD_NAV_WAYPOINT:
            if self._go(where, item, required=True) and (p[0] or 0) > 0:
                self._add("sleep", value=p[0])
        elif command == mav.MAV_CMD_NAV_TAKEOFF:
            if not any(s["command"] == "arm" for s in self.steps):
                self._add("arm")
            height = self._height(where, item)
            self._add("takeoff", **({"value": height} if height else {}))
            self._add("wait_for_flight")
        elif command == mav.MAV_CMD_NAV_LAND:
            self._go(where, item, required=False)
            self._add("land")
            self._add("wait_for_flight")
        elif command == mav.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            self._add("rtl")
            self._add("wait_for_flight")
        elif command in (mav.MAV_CMD_NAV_LOITER_TIME, mav.MAV_CMD_NAV_DELAY):
            if command == mav.MAV_CMD_NAV_LOITER_TIME:
                self._go(where, item, required=False)
            if (p[0] or 0) >= 0:
                self._add("sleep", value=p[0] or 0.0)
            else:
                self.warnings.append(f"{where}: a delay until a time of day is left out")
        elif command == mav.MAV_CMD_DO_DIGICAM_CONTROL or (
            command == mav.MAV_CMD_IMAGE_START_CAPTURE and p[2] == 1
        ):
            self._add("takepic")
        elif command == mav.MAV_CMD_DO_SET_CAM_TRIGG_DIST:
            self._add("camera_trigger", value=max(0.0, p[0] or 0.0))
        elif _is_nav(command) or command in _UNFLYABLE:
            raise MissionFileError(
                f".plan: {where}: {_command_name(command)} cannot be flown by dronefleet"
            )
        else:
            self.warnings.append(f"{where}: {_command_name(command)} left out (no such step)")

    def _go(self, where: str, item: SimpleItem, *, required: bool) -> bool:
        """Fly to the item's position (a ``navigate`` and its wait); False if it has none."""
        lat, lon = item.params[4], item.params[5]
        if lat is None or lon is None or (lat == 0 and lon == 0):
            if required:
                self.warnings.append(f"{where}: a waypoint with no position is left out")
            return False
        if not (-90 <= lat <= 90 and -180 <= lon <= 180):
            raise MissionFileError(f".plan: {where}: [{lat}, {lon}] is not a [lat, lon] position")
        step: dict[str, Any] = {"lat": lat, "lon": lon}
        height = self._height(where, item)
        if height is not None:
            step["altitude_delta"] = height
        self._add("navigate", **step)
        self._add("wait_for_flight")
        return True

    def _height(self, where: str, item: SimpleItem) -> float | None:
        """The item's altitude as a height above home (m), or None when it gives none."""
        alt, frame = item.params[6], item.frame
        if alt is None:
            return None
        if frame in TERRAIN_FRAMES:
            self.warnings.append(f"{where}: {alt:g} m above terrain flown as {alt:g} m above home")
        elif frame in ABSOLUTE_FRAMES:
            if self.home is None:
                raise MissionFileError(
                    f".plan: {where}: an altitude above sea level needs plannedHomePosition"
                )
            alt -= self.home.alt_m
        elif frame not in RELATIVE_FRAMES:
            raise MissionFileError(f".plan: {where}: frame {frame} is not a global frame")
        if alt < 0:
            raise MissionFileError(f".plan: {where}: {alt:.1f} m is below home")
        return alt

    def _add(self, command: str, **fields: Any) -> None:
        self.steps.append({"command": command, **fields})


def _is_nav(command: int) -> bool:
    """MAVLink's NAV commands are numbered below 100 (DO from 176, conditions 112-159)."""
    return command < 100


# -- fence and rally points ----------------------------------------------------------------------
def circle_corners(circle: Circle, *, outside: bool) -> list[list[float]]:
    """A circle as a polygon of :data:`CIRCLE_SIDES`: inside it (``outside`` False, for a zone
    to stay in) or around it (for a zone to stay out of), so the polygon never allows more."""
    centre = LLA(circle.center[0], circle.center[1])
    radius = circle.radius / math.cos(math.pi / CIRCLE_SIDES) if outside else circle.radius
    corners = []
    for k in range(CIRCLE_SIDES):
        a = 2 * math.pi * k / CIRCLE_SIDES
        p = offset(centre, radius * math.cos(a), radius * math.sin(a))
        corners.append([p.lat, p.lon])
    return corners


def _fence(plan: PlanFile, warnings: list[str]) -> dict[str, Any] | None:
    fence = plan.geoFence
    inclusions = [[list(p) for p in z.polygon] for z in fence.polygons if z.inclusion]
    inclusions += [circle_corners(c.circle, outside=False) for c in fence.circles if c.inclusion]
    exclusions = [[list(p) for p in z.polygon] for z in fence.polygons if not z.inclusion]
    exclusions += [circle_corners(c.circle, outside=True) for c in fence.circles if not c.inclusion]
    if fence.circles:
        warnings.append(f"fence circles are kept as {CIRCLE_SIDES}-sided polygons")
    if len(inclusions) > 1:
        raise MissionFileError(
            f".plan: the fence has {len(inclusions)} inclusion zones; dronefleet keeps one"
            " (merge them into one polygon)"
        )
    ceiling = plan.dronefleet.fence_ceiling_m if plan.dronefleet else None
    if not (inclusions or exclusions or ceiling):
        return None
    out: dict[str, Any] = {"exclusions": exclusions}
    if inclusions:
        out["inclusion"] = inclusions[0]
    if ceiling:
        out["ceiling_m"] = ceiling
    return out


def _rally(rally: PlanRally, warnings: list[str]) -> list[dict[str, Any]]:
    points = []
    for k, point in enumerate(rally.points):
        if len(point) < 2 or point[0] is None or point[1] is None:
            raise MissionFileError(f".plan: rally point {k + 1} is not [lat, lon, alt]")
        alt = point[2] if len(point) > 2 and point[2] is not None else None
        if alt is None or alt <= 0:
            warnings.append(f"rally point {k + 1}: no height above home; 15 m used")
            alt = 15.0
        points.append({"lat": point[0], "lon": point[1], "alt_m": alt})
    return points
