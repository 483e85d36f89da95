"""A mission written as a QGroundControl ``.plan`` file (issue 14): the work steps as mission
items, the geofence and the rally points, in the format QGroundControl and MAVSDK's
``import_qgroundcontrol_mission`` read (tests/integration/mavlink/independent).

Steps → items (the reverse of :mod:`.plan`; MAVLink numbers from pymavlink's dialect, as the
drone's own on-board missions use): ``takeoff`` NAV_TAKEOFF, ``navigate`` and the relative moves
(``changeN``, ``changeE``, ``altitude``, made absolute from the last position) NAV_WAYPOINT,
``sleep`` right after a waypoint its hold time (param1), any other ``sleep`` and
``read_sensors`` NAV_LOITER_TIME where the drone is, ``land`` NAV_LAND, ``rtl``
NAV_RETURN_TO_LAUNCH, ``takepic`` DO_DIGICAM_CONTROL, ``camera_trigger`` DO_SET_CAM_TRIGG_DIST.
``arm`` and ``wait_for_flight`` have no item (a ground station arms; the autopilot waits by
itself); alarms and the other controller commands are not a flight and are left out. Positions
are in the relative-altitude frame (heights above home, as the planner's are). The fence ceiling,
which the format has no place for, goes in our own ``dronefleet`` key.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict

from dronefleet.geo.distance import offset
from dronefleet.geo.types import LLA
from dronefleet.protocols.mavlink.codec import dialect as mav

#: What the file says it was planned for: ArduPilot (MAV_AUTOPILOT_ARDUPILOTMEGA), a quadrotor.
FIRMWARE_TYPE = mav.MAV_AUTOPILOT_ARDUPILOTMEGA
VEHICLE_TYPE = mav.MAV_TYPE_QUADROTOR
#: Height of waypoints before any step gives one (the planner's default take-off height).
DEFAULT_HEIGHT_M = 10.0
_RELATIVE = mav.MAV_FRAME_GLOBAL_RELATIVE_ALT
_MISSION = mav.MAV_FRAME_MISSION


class PlanDocument(BaseModel):
    """A .plan as written here: what the export routes answer (the OpenAPI schema says so)."""

    model_config = ConfigDict(extra="allow")
    fileType: Literal["Plan"]
    version: Literal[1]
    groundStation: str
    mission: dict[str, Any]
    geoFence: dict[str, Any]
    rallyPoints: dict[str, Any]


class _Writer:
    def __init__(self, home: LLA) -> None:
        self.items: list[dict[str, Any]] = []
        self.at = LLA(home.lat, home.lon, DEFAULT_HEIGHT_M)  # alt_m: height above home

    def item(self, command: int, frame: int, params: list[float | None]) -> None:
        self.items.append(
            {
                "type": "SimpleItem",
                "autoContinue": True,
                "command": command,
                "doJumpId": len(self.items) + 1,
                "frame": frame,
                "params": params,
            }
        )

    def waypoint(self, to: LLA) -> None:
        self.at = to
        self.item(mav.MAV_CMD_NAV_WAYPOINT, _RELATIVE, [0, 0, 0, None, to.lat, to.lon, to.alt_m])

    def _holds_at_waypoint(self, seconds: float) -> bool:
        """Make ``seconds`` the hold time of the waypoint just written, if it has none yet."""
        last = self.items[-1] if self.items else None
        if last is None or last["command"] != mav.MAV_CMD_NAV_WAYPOINT or last["params"][0]:
            return False
        last["params"][0] = seconds
        return True

    def step(self, step: dict[str, Any]) -> None:
        command, given = step.get("command"), step.get("value")
        value = float(given) if isinstance(given, int | float) else None
        at = self.at
        if command == "takeoff":
            height = value if value is not None else at.alt_m
            self.at = LLA(at.lat, at.lon, height)
            self.item(mav.MAV_CMD_NAV_TAKEOFF, _RELATIVE, [0, 0, 0, None, 0, 0, height])
        elif command == "navigate":
            given = step.get("altitude_delta")
            height = float(given) if isinstance(given, int | float) else at.alt_m
            self.waypoint(LLA(step["lat"], step["lon"], height))
        elif command in ("changeN", "changeE"):
            metres = value or 0.0
            north, east = (metres, 0.0) if command == "changeN" else (0.0, metres)
            moved = offset(LLA(at.lat, at.lon), north, east)
            self.waypoint(LLA(moved.lat, moved.lon, at.alt_m))
        elif command == "altitude":
            self.waypoint(LLA(at.lat, at.lon, max(0.0, at.alt_m + (value or 0.0))))
        elif command == "sleep" and self._holds_at_waypoint(value or 0.0):
            pass  # a stop at the waypoint just reached: its hold time, as QGroundControl writes
        elif command in ("sleep", "read_sensors"):
            seconds = value or 0.0
            self.item(
                mav.MAV_CMD_NAV_LOITER_TIME, _RELATIVE, [seconds, 0, 0, None, at.lat, at.lon,
                                                         at.alt_m],
            )  # fmt: skip
        elif command == "land":
            self.item(mav.MAV_CMD_NAV_LAND, _RELATIVE, [0, 0, 0, None, 0, 0, 0])
        elif command == "rtl":
            self.item(mav.MAV_CMD_NAV_RETURN_TO_LAUNCH, _MISSION, [0, 0, 0, 0, 0, 0, 0])
        elif command == "takepic":  # param5 "shoot"
            self.item(mav.MAV_CMD_DO_DIGICAM_CONTROL, _MISSION, [0, 0, 0, 0, 1, 0, 0])
        elif command == "camera_trigger":
            metres = value or 0.0
            trigger: list[float | None] = [metres, 0, 1 if metres > 0 else 0, 0, 0, 0, 0]
            self.item(mav.MAV_CMD_DO_SET_CAM_TRIGG_DIST, _MISSION, trigger)


def write_plan(
    steps: list[dict[str, Any]],
    *,
    home: LLA | None,
    geofence: dict[str, Any] | None = None,
    rally_points: list[dict[str, Any]] | None = None,
    cruise_speed_mps: float = 10.0,
) -> dict[str, Any]:
    """The .plan document of ``steps`` (the mission's work, as the drones get it), its fence
    (``Geofence`` as JSON) and rally points (``RallyPoint`` s as JSON). ``home`` (AMSL
    altitude) is the plan's planned home; without one, the first waypoint's place is used."""
    if home is None:
        first = next((s for s in steps if s.get("command") == "navigate"), None)
        home = LLA(first["lat"], first["lon"], 0.0) if first else LLA(0.0, 0.0, 0.0)
    writer = _Writer(home)
    for step in steps:
        writer.step(step)
    fence = geofence or {}
    polygons = []
    if fence.get("inclusion"):
        polygons.append({"inclusion": True, "polygon": fence["inclusion"], "version": 1})
    for zone in fence.get("exclusions") or []:
        polygons.append({"inclusion": False, "polygon": zone, "version": 1})
    document: dict[str, Any] = {
        "fileType": "Plan",
        "version": 1,
        "groundStation": "dronefleet",
        "mission": {
            "version": 2,
            "firmwareType": FIRMWARE_TYPE,
            "vehicleType": VEHICLE_TYPE,
            "cruiseSpeed": cruise_speed_mps,
            "hoverSpeed": cruise_speed_mps,
            "plannedHomePosition": [home.lat, home.lon, home.alt_m],
            "items": writer.items,
        },
        "geoFence": {"version": 2, "circles": [], "polygons": polygons},
        "rallyPoints": {
            "version": 2,
            "points": [[p["lat"], p["lon"], p["alt_m"]] for p in rally_points or []],
        },
    }
    if fence.get("ceiling_m"):
        document["dronefleet"] = {"fence_ceiling_m": fence["ceiling_m"]}
    return document
