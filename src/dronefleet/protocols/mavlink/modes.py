"""Flight modes over MAVLink: ArduPilot Copter mode numbers and PX4's main/sub modes.

HEARTBEAT.custom_mode means different things per autopilot (seed 6.2.4 names MAVLink as the next
step; today ArduPilot and PX4 are the two that matter):

* ArduPilot Copter: ``custom_mode`` is the mode number (STABILIZE 0, AUTO 3, GUIDED 4, RTL 6,
  LAND 9, BRAKE 17, …). Position targets are flown in GUIDED; a mission in AUTO.
* PX4: ``custom_mode`` packs ``main_mode`` in bits 16-23 and ``sub_mode`` in bits 24-31
  (AUTO = 4 with sub modes TAKEOFF 2, LOITER 3, MISSION 4, RTL 5, LAND 6; OFFBOARD = 6).
  PX4's GUIDED equivalent, OFFBOARD, needs a setpoint stream at > 2 Hz, so the backend flies
  single targets in AUTO.LOITER with MAV_CMD_DO_REPOSITION and takes off with NAV_TAKEOFF in
  AUTO.TAKEOFF (altitude AMSL) instead — see drone/fc/mavlink/guided.py. So AUTO.LOITER is both our
  GUIDED and a HOLD: :func:`decode_mode` says HOLD, and the controller says GUIDED for the
  AUTO.LOITER it commanded itself (drone/fc/mavlink/mode_watch.py, ``_on_mode``).

Everything above the backend sees only :class:`~dronefleet.vehicle.base.FlightMode`.
"""

from __future__ import annotations

import enum

from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.vehicle.base import FlightMode


class Autopilot(enum.Enum):
    ARDUPILOT = "ardupilot"
    PX4 = "px4"
    GENERIC = "generic"

    @classmethod
    def from_heartbeat(cls, autopilot: int) -> Autopilot:
        if autopilot == mav.MAV_AUTOPILOT_ARDUPILOTMEGA:
            return cls.ARDUPILOT
        if autopilot == mav.MAV_AUTOPILOT_PX4:
            return cls.PX4
        return cls.GENERIC


class CopterMode(enum.IntEnum):
    """ArduPilot Copter flight mode numbers (HEARTBEAT.custom_mode)."""

    STABILIZE = 0
    ACRO = 1
    ALT_HOLD = 2
    AUTO = 3
    GUIDED = 4
    LOITER = 5
    RTL = 6
    CIRCLE = 7
    LAND = 9
    DRIFT = 11
    SPORT = 13
    FLIP = 14
    AUTOTUNE = 15
    POSHOLD = 16
    BRAKE = 17
    THROW = 18
    AVOID_ADSB = 19
    GUIDED_NOGPS = 20
    SMART_RTL = 21


_COPTER_TO_FLIGHT = {
    CopterMode.GUIDED: FlightMode.GUIDED,
    CopterMode.AUTO: FlightMode.MISSION,
    CopterMode.RTL: FlightMode.RTL,
    CopterMode.SMART_RTL: FlightMode.RTL,
    CopterMode.LAND: FlightMode.LAND,
    CopterMode.BRAKE: FlightMode.HOLD,
    CopterMode.LOITER: FlightMode.HOLD,
    CopterMode.POSHOLD: FlightMode.HOLD,
}
_FLIGHT_TO_COPTER = {
    FlightMode.STABILIZE: CopterMode.STABILIZE,
    FlightMode.GUIDED: CopterMode.GUIDED,
    FlightMode.HOLD: CopterMode.BRAKE,  # needs no RC sticks, unlike LOITER/POSHOLD
    FlightMode.LAND: CopterMode.LAND,
    FlightMode.RTL: CopterMode.RTL,
    FlightMode.MISSION: CopterMode.AUTO,
}


class Px4Main(enum.IntEnum):
    MANUAL = 1
    ALTCTL = 2
    POSCTL = 3
    AUTO = 4
    ACRO = 5
    OFFBOARD = 6
    STABILIZED = 7


class Px4Auto(enum.IntEnum):
    READY = 1
    TAKEOFF = 2
    LOITER = 3
    MISSION = 4
    RTL = 5
    LAND = 6


_PX4_FROM_FLIGHT: dict[FlightMode, tuple[Px4Main, int]] = {
    FlightMode.STABILIZE: (Px4Main.STABILIZED, 0),
    FlightMode.GUIDED: (Px4Main.AUTO, Px4Auto.LOITER),  # targets via DO_REPOSITION
    FlightMode.HOLD: (Px4Main.AUTO, Px4Auto.LOITER),
    FlightMode.LAND: (Px4Main.AUTO, Px4Auto.LAND),
    FlightMode.RTL: (Px4Main.AUTO, Px4Auto.RTL),
    FlightMode.MISSION: (Px4Main.AUTO, Px4Auto.MISSION),
}


def px4_custom_mode(main: int, sub: int = 0) -> int:
    return (main << 16) | (sub << 24)


def decode_mode(autopilot: Autopilot, custom_mode: int) -> FlightMode:
    """The project's flight mode for a HEARTBEAT's ``custom_mode``."""
    if autopilot is Autopilot.PX4:
        main, sub = (custom_mode >> 16) & 0xFF, (custom_mode >> 24) & 0xFF
        if main == Px4Main.OFFBOARD:
            return FlightMode.GUIDED
        if main == Px4Main.AUTO:
            px4_auto: dict[int, FlightMode] = {
                Px4Auto.MISSION: FlightMode.MISSION,
                Px4Auto.RTL: FlightMode.RTL,
                Px4Auto.LAND: FlightMode.LAND,
                Px4Auto.TAKEOFF: FlightMode.GUIDED,
            }
            return px4_auto.get(sub, FlightMode.HOLD)
        return FlightMode.HOLD if main == Px4Main.POSCTL else FlightMode.STABILIZE
    try:
        return _COPTER_TO_FLIGHT.get(CopterMode(custom_mode), FlightMode.STABILIZE)
    except ValueError:
        return FlightMode.STABILIZE


def mode_name(autopilot: Autopilot, custom_mode: int) -> str:
    """The autopilot's own name for a mode, e.g. ``GUIDED`` or ``AUTO.MISSION``."""
    if autopilot is Autopilot.PX4:
        main, sub = (custom_mode >> 16) & 0xFF, (custom_mode >> 24) & 0xFF
        try:
            name = Px4Main(main).name
        except ValueError:
            return f"PX4 mode {main}/{sub}"
        if main == Px4Main.AUTO:
            try:
                return f"AUTO.{Px4Auto(sub).name}"
            except ValueError:
                return f"AUTO.{sub}"
        return name
    try:
        return CopterMode(custom_mode).name
    except ValueError:
        return f"mode {custom_mode}"


def set_mode_params(autopilot: Autopilot, mode: FlightMode) -> tuple[float, float, float]:
    """``MAV_CMD_DO_SET_MODE`` params 1-3 (base mode flag, custom mode, custom sub mode)."""
    flag = float(mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED)
    if autopilot is Autopilot.PX4:
        main, sub = _PX4_FROM_FLIGHT[mode]
        return flag, float(main), float(sub)
    return flag, float(_FLIGHT_TO_COPTER[mode]), 0.0


def custom_mode_for(autopilot: Autopilot, mode: FlightMode) -> int:
    """The ``custom_mode`` a HEARTBEAT shows once ``mode`` is active."""
    if autopilot is Autopilot.PX4:
        main, sub = _PX4_FROM_FLIGHT[mode]
        return px4_custom_mode(main, sub)
    return int(_FLIGHT_TO_COPTER[mode])
