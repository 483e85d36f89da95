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
    return MissionItem(mav.MAV_CMD_NAV_LAND).at(lat, lon)


def return_to_launch() -> MissionItem:
    return MissionItem(mav.MAV_CMD_NAV_RETURN_TO_LAUNCH)


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
