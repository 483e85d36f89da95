"""Raw object requests (the seed's ``objrequest``) answered from MAVLink messages.

The seed's controller asked dRonin for UAVObjects by name (section 4.1.2.1). Over MAVLink the
backend answers two kinds of names: any MAVLink message type (``ATTITUDE``, ``SYS_STATUS``, …, the
latest one received, as a dict of its fields), and the UAVObject names the in-process sim backend
answers (``GPSPosition``, ``FlightStatus``, …), built from the matching MAVLink messages with the
same keys and units, so a ground station's objrequest behaves the same whatever flies.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from dronefleet.geo.ned import lla_to_ned
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.protocols.mavlink.codec import message_id, to_dict
from dronefleet.vehicle.base import FcError
from dronefleet.vehicle.views import flight_battery_state

if TYPE_CHECKING:
    from dronefleet.drone.fc.mavlink.controller import MavlinkFlightController

_GPS_FIX = {0: "NoGPS", 1: "NoFix", 2: "Fix2D", 3: "Fix3D", 4: "Fix3D", 5: "Fix3D", 6: "Fix3D"}


async def request_object(fc: MavlinkFlightController, name: str) -> dict[str, Any]:
    """``name`` as a UAVObject view, or the latest MAVLink message of that type (asked for with
    MAV_CMD_REQUEST_MESSAGE when none has come yet)."""
    view = uavobject(fc, name)
    if view is not None:
        return view
    kind = name.upper()
    try:
        msg_id = message_id(kind)
    except KeyError:
        known = ", ".join(uavobject_names())
        raise FcError(
            f"unknown object {name!r}; known: {known}, or any MAVLink message name"
        ) from None
    if kind not in fc.link.latest:
        try:
            await fc.commands.long(mav.MAV_CMD_REQUEST_MESSAGE, msg_id)
        except FcError as exc:
            raise FcError(f"{name}: the autopilot does not send it ({exc})") from exc
        if await fc.link.wait_for(kind, timeout_s=2.0) is None:
            raise FcError(f"{name}: requested, but the autopilot sent none")
    return to_dict(fc.link.latest[kind])


def uavobject(fc: MavlinkFlightController, name: str) -> dict[str, Any] | None:
    """The UAVObject-like view ``name``, or None when it is not one we map."""
    build = _BUILDERS.get(name)
    return None if build is None else build(fc)


def uavobject_names() -> list[str]:
    return sorted(_BUILDERS)


def _gps_position(fc: MavlinkFlightController) -> dict[str, Any]:
    fix, vel = fc.position(), fc.velocity()
    raw = fc.link.latest.get("GPS_RAW_INT")
    return {
        "Latitude": fix.lat,
        "Longitude": fix.lon,
        "Altitude": fix.alt_m,
        "Groundspeed": vel.horizontal_m,
        "Heading": math.degrees(math.atan2(vel.e, vel.n)) % 360.0,
        "Satellites": raw.satellites_visible if raw else 0,
        "HDOP": raw.eph / 100.0 if raw else 99.99,
        "Status": _GPS_FIX.get(raw.fix_type, "Fix3D") if raw else "NoGPS",
        "FixTime": raw.time_usec / 1e6 if raw else 0.0,
    }


def _attitude_actual(fc: MavlinkFlightController) -> dict[str, Any]:
    att = fc.attitude()
    return {"Roll": att.roll_deg, "Pitch": att.pitch_deg, "Yaw": att.yaw_deg}


def _flight_status(fc: MavlinkFlightController) -> dict[str, Any]:
    state = fc.state()
    armed = "Armed" if state.armed else "Arming" if state.arming else "Disarmed"
    return {
        "Armed": armed,
        "FlightMode": state.mode.value,
        "AutopilotMode": fc.mode_name(),
        "InAir": state.in_air,
        "Landing": state.landing,
        "Rebooting": fc.rebooting,
        "Link": "Connected" if fc.link.link_ok else "Lost",
        "HeartbeatAge": fc.link.heartbeat_age_s(),
    }


def _flight_battery_state(fc: MavlinkFlightController) -> dict[str, Any]:
    return flight_battery_state(fc.battery())


def _position_actual(fc: MavlinkFlightController) -> dict[str, Any]:
    ned = lla_to_ned(fc.position(), fc.home())
    return {"North": ned.n, "East": ned.e, "Down": ned.d}


def _velocity_actual(fc: MavlinkFlightController) -> dict[str, Any]:
    vel = fc.velocity()
    return {"North": vel.n, "East": vel.e, "Down": vel.d}


def _accels(fc: MavlinkFlightController) -> dict[str, Any]:
    imu = fc.link.latest.get("SCALED_IMU") or fc.link.latest.get("RAW_IMU")
    if imu is None:
        return {"x": 0.0, "y": 0.0, "z": -9.80665}
    g = 9.80665 / 1000.0  # milli-g to m/s²
    return {"x": imu.xacc * g, "y": imu.yacc * g, "z": imu.zacc * g}


def _home_location(fc: MavlinkFlightController) -> dict[str, Any]:
    home = fc.home()
    return {"Latitude": home.lat, "Longitude": home.lon, "Altitude": home.alt_m, "Set": True}


_BUILDERS = {
    "GPSPosition": _gps_position,
    "AttitudeActual": _attitude_actual,
    "FlightStatus": _flight_status,
    "FlightBatteryState": _flight_battery_state,
    "PositionActual": _position_actual,
    "VelocityActual": _velocity_actual,
    "Accels": _accels,
    "HomeLocation": _home_location,
}
