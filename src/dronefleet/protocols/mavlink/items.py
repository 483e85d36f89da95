"""Mission items as flown on board (MISSION_ITEM_INT), shared by the backend and the simulator.

A mission uploaded to the autopilot is flown by the autopilot itself, so the drone keeps flying it
when the link to the ground (or to the companion computer) is lost — the answer to the seed's
"what if the connection drops" (sections 3.3.3, 6.2). Positions are ``x``/``y`` in 1e-7 degrees
and ``z`` in metres in the item's frame (relative to home by default, as ArduPilot expects).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from dronefleet.protocols.mavlink.codec import Message
from dronefleet.protocols.mavlink.codec import dialect as mav

RELATIVE = mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
ABSOLUTE = mav.MAV_FRAME_GLOBAL_INT
MISSION = mav.MAV_MISSION_TYPE_MISSION
FENCE = mav.MAV_MISSION_TYPE_FENCE
RALLY = mav.MAV_MISSION_TYPE_RALLY

#: Commands the autopilot flies to (the rest are "DO" commands run along the way).
NAV_COMMANDS = frozenset(
    {
        mav.MAV_CMD_NAV_WAYPOINT,
        mav.MAV_CMD_NAV_TAKEOFF,
        mav.MAV_CMD_NAV_LAND,
        mav.MAV_CMD_NAV_RETURN_TO_LAUNCH,
        mav.MAV_CMD_NAV_LOITER_TIME,
        mav.MAV_CMD_NAV_LOITER_UNLIM,
        mav.MAV_CMD_NAV_DELAY,
    }
)


@dataclass(frozen=True, slots=True)
class MissionItem:
    command: int
    x: int = 0  # latitude, 1e-7 degrees (0: where the vehicle is)
    y: int = 0  # longitude, 1e-7 degrees
    z: float = 0.0  # altitude in metres in ``frame``
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    frame: int = RELATIVE
    autocontinue: int = 1

    @property
    def is_nav(self) -> bool:
        return self.command in NAV_COMMANDS

    @property
    def lat(self) -> float:
        return self.x / 1e7

    @property
    def lon(self) -> float:
        return self.y / 1e7

    def to_message(
        self, target_system: int, target_component: int, seq: int, mission_type: int = MISSION
    ) -> Message:
        return mav.MAVLink_mission_item_int_message(
            target_system,
            target_component,
            seq,
            self.frame,
            self.command,
            0,
            self.autocontinue,
            self.param1,
            self.param2,
            self.param3,
            self.param4,
            self.x,
            self.y,
            self.z,
            mission_type,
        )

    @classmethod
    def from_message(cls, msg: Message) -> MissionItem:
        """From MISSION_ITEM_INT, or the deprecated float MISSION_ITEM some stations send."""
        x, y = msg.x, msg.y
        if msg.get_type() == "MISSION_ITEM":
            x, y = round(x * 1e7), round(y * 1e7)
            frame = {
                mav.MAV_FRAME_GLOBAL: ABSOLUTE,
                mav.MAV_FRAME_GLOBAL_RELATIVE_ALT: RELATIVE,
            }.get(msg.frame, msg.frame)
        else:
            frame = msg.frame
        return cls(
            msg.command,
            int(x),
            int(y),
            float(msg.z),
            msg.param1,
            msg.param2,
            msg.param3,
            msg.param4,
            frame,
            msg.autocontinue,
        )

    def at(self, lat: float, lon: float) -> MissionItem:
        return replace(self, x=round(lat * 1e7), y=round(lon * 1e7))


# -- builders (altitudes in metres above home) ---------------------------------------------------
def takeoff(altitude_m: float) -> MissionItem:
    return MissionItem(mav.MAV_CMD_NAV_TAKEOFF, z=altitude_m)


def waypoint(lat: float, lon: float, altitude_m: float, hold_s: float = 0.0) -> MissionItem:
    return MissionItem(mav.MAV_CMD_NAV_WAYPOINT, z=altitude_m, param1=hold_s).at(lat, lon)


def loiter_time(lat: float, lon: float, altitude_m: float, seconds: float) -> MissionItem:
    return MissionItem(mav.MAV_CMD_NAV_LOITER_TIME, z=altitude_m, param1=seconds).at(lat, lon)


def land(lat: float = 0.0, lon: float = 0.0) -> MissionItem:
    """NAV_LAND; 0, 0: where the vehicle is then, which :func:`placed` writes in."""
    return MissionItem(mav.MAV_CMD_NAV_LAND).at(lat, lon)


def return_to_launch() -> MissionItem:
    """NAV_RETURN_TO_LAUNCH (20): the autopilot's own RTL (ArduPilot: to RTL_ALT, home or the
    nearest rally point, land)."""
    return MissionItem(mav.MAV_CMD_NAV_RETURN_TO_LAUNCH)


def loiter_unlimited(lat: float, lon: float, altitude_m: float) -> MissionItem:
    """NAV_LOITER_UNLIM (17): hold there until told otherwise (a mission that ends in the air)."""
    return MissionItem(mav.MAV_CMD_NAV_LOITER_UNLIM, z=altitude_m).at(lat, lon)


#: NAV items whose 0, 0 means "where the vehicle is" to the builders above.
_HERE_WHEN_ZERO = frozenset({mav.MAV_CMD_NAV_TAKEOFF, mav.MAV_CMD_NAV_LAND})


def placed(items: list[MissionItem], lat: float, lon: float) -> list[MissionItem]:
    """``items`` with no 0, 0 they do not mean: a NAV_TAKEOFF or NAV_LAND left at 0, 0 gets
    the place the vehicle will be when it flies it — the last position before it in the
    mission, else ``lat``, ``lon`` (the vehicle now). ArduPilot reads 0, 0 there as
    "the current location", but PX4 flies to it (measured on SITL b765769f50: a take-off item at
    0, 0 sent the vehicle towards 0°N 0°E), and MISSION_ITEM_INT's int32 x/y cannot carry the
    NaN "use the current position" of MISSION_ITEM (MAVLink common.xml). Copter's take-off only
    climbs and its land at a position flies there first, which here is where it already is."""
    last = (round(lat * 1e7), round(lon * 1e7))
    out: list[MissionItem] = []
    for item in items:
        if item.command in _HERE_WHEN_ZERO and item.x == 0 and item.y == 0:
            item = replace(item, x=last[0], y=last[1])
        elif item.is_nav and (item.x, item.y) != (0, 0):
            last = (item.x, item.y)
        out.append(item)
    return out


#: Items that carry a position (x/y/z): every other one goes as MAV_FRAME_MISSION to PX4.
_POSITIONED = frozenset(
    {
        mav.MAV_CMD_NAV_WAYPOINT,
        mav.MAV_CMD_NAV_TAKEOFF,
        mav.MAV_CMD_NAV_LAND,
        mav.MAV_CMD_NAV_LOITER_TIME,
        mav.MAV_CMD_NAV_LOITER_UNLIM,
        mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
        mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION,
        mav.MAV_CMD_NAV_RALLY_POINT,
    }
)


def px4_frames(items: list[MissionItem]) -> list[MissionItem]:
    """``items`` as PX4 takes them: an item without a position (NAV_RETURN_TO_LAUNCH,
    DO_CHANGE_SPEED, …) in MAV_FRAME_MISSION. PX4's MavlinkMissionManager
    (src/modules/mavlink/mavlink_mission.cpp, parse_mavlink_mission_item) reads those commands
    only in that frame and refuses them in a global one (MAV_MISSION_UNSUPPORTED; measured on
    SITL b765769f50: "IGN MISSION_ITEM: Invalid item" for an RTL in the relative frame)."""
    return [
        item if item.command in _POSITIONED else replace(item, frame=mav.MAV_FRAME_MISSION)
        for item in items
    ]


# -- which mission steps an autopilot flies on board ---------------------------------------------
#: The mission steps (by command name, messaging/commands.py) that have an on-board form
#: (drone/onboard.py): ``arm`` (from the companion computer, before any flying step),
#: ``takeoff`` NAV_TAKEOFF, ``navigate`` NAV_WAYPOINT, ``wait_for_flight`` (the NAV item before
#: it reached), ``sleep`` NAV_LOITER_TIME, ``takepic`` DO_DIGICAM_CONTROL, ``camera_trigger``
#: DO_SET_CAM_TRIGG_DIST, ``land`` NAV_LAND, ``rtl`` NAV_RETURN_TO_LAUNCH; a mission that ends
#: in the air ends with NAV_LOITER_UNLIM. Shared by the drone and the planner, which refuses a
#: mission asked on board that has another step.
ONBOARD_STEPS = frozenset(
    {
        "arm",
        "takeoff",
        "navigate",
        "wait_for_flight",
        "sleep",
        "takepic",
        "camera_trigger",
        "land",
        "rtl",
    }
)


def onboard_refusal(commands: list[str]) -> tuple[int, str] | None:
    """The first step of ``commands`` that cannot be flown on board and why (its index, a
    sentence), or None when all can."""
    flying = False
    for i, command in enumerate(commands):
        if command not in ONBOARD_STEPS:
            return i, f"{command} has no on-board (MAVLink mission item) form"
        if command == "arm" and flying:
            return i, "arm between flying steps is left to the companion computer"
        flying = flying or command != "arm"
    return None


def take_photo() -> MissionItem:
    """DO_DIGICAM_CONTROL with "shoot" set: one picture where the vehicle is."""
    # "shoot" is param5, which MISSION_ITEM_INT carries in ``x``.
    return MissionItem(mav.MAV_CMD_DO_DIGICAM_CONTROL, x=1, frame=mav.MAV_FRAME_MISSION)


def trigger_distance(distance_m: float) -> MissionItem:
    """DO_SET_CAM_TRIGG_DIST: a picture every ``distance_m`` flown, the first at once (param3 1);
    zero stops it. How QGroundControl's surveys photograph a line without stopping."""
    return MissionItem(
        mav.MAV_CMD_DO_SET_CAM_TRIGG_DIST,
        param1=distance_m,
        param3=1.0 if distance_m > 0 else 0.0,
        frame=mav.MAV_FRAME_MISSION,
    )


def change_speed(speed_mps: float) -> MissionItem:
    return MissionItem(mav.MAV_CMD_DO_CHANGE_SPEED, param1=1.0, param2=speed_mps)


# -- geofence and rally points (mission_type FENCE and RALLY) ------------------------------------
def fence_vertex(lat: float, lon: float, vertices: int, *, inclusion: bool) -> MissionItem:
    """One corner of a fence polygon of ``vertices`` corners (param1), as ArduPilot's
    AC_PolyFence_loader and QGroundControl's fence items have it."""
    command = (
        mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
        if inclusion
        else mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION
    )
    return MissionItem(command, param1=float(vertices), frame=mav.MAV_FRAME_GLOBAL).at(lat, lon)


def rally_point(lat: float, lon: float, altitude_m: float) -> MissionItem:
    """A rally point ``altitude_m`` above home (ArduPilot's AP_Rally: relative frame)."""
    return MissionItem(mav.MAV_CMD_NAV_RALLY_POINT, z=altitude_m).at(lat, lon)
