"""What the autopilot says it is doing: the never-blocking state getters of the ``mavlink``
backend, read from the latest messages on the link (Flight Controller Interface, seed 4.1.2.1).

Position and velocity come from GLOBAL_POSITION_INT, home from HOME_POSITION, battery from
SYS_STATUS and BATTERY_STATUS, attitude from ATTITUDE; armed and mode from HEARTBEAT, and whether
the vehicle is in the air from EXTENDED_SYS_STATE (or, for autopilots that do not send it, from
HEARTBEAT.system_status ACTIVE/STANDBY, as ArduPilot sets it).
"""

from __future__ import annotations

import math
from collections.abc import AsyncIterator

from dronefleet.drone.fc.clock import AutopilotClock
from dronefleet.drone.fc.mavlink.link import MavlinkLink
from dronefleet.geo.types import LLA, NED
from dronefleet.protocols.mavlink.codec import Message
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.protocols.mavlink.modes import Autopilot, decode_mode, mode_name
from dronefleet.vehicle.base import (
    Attitude,
    BatteryState,
    FcError,
    FlightMode,
    GpsFix,
    GpsState,
    VehicleState,
    WindEstimate,
    telemetry_sample,
)

#: MAVLink GPS_FIX_TYPE: 0 no GPS, 1 no fix, 2 2-D, 3 3-D, 4 DGPS, 5-6 RTK (and 3-D).
_GPS_FIX = {0: GpsFix.NO_GPS, 1: GpsFix.NO_FIX, 2: GpsFix.FIX_2D}
_IN_AIR_STATES = {
    mav.MAV_LANDED_STATE_IN_AIR,
    mav.MAV_LANDED_STATE_TAKEOFF,
    mav.MAV_LANDED_STATE_LANDING,
}


class VehicleView:
    """State getters over ``self.link`` (mixed into the controller)."""

    link: MavlinkLink
    autopilot: Autopilot
    telemetry_rate_hz: float
    _clock: AutopilotClock
    _arming: bool
    _closed: bool
    _capacity_mah: float

    def _name(self) -> str:
        return f"autopilot {self.link.target_system or '?'}"

    def position(self) -> LLA:
        pos = self.link.latest.get("GLOBAL_POSITION_INT")
        if pos is None:
            return self.home()
        return LLA(pos.lat / 1e7, pos.lon / 1e7, pos.alt / 1000.0)

    def home(self) -> LLA:
        home = self.link.latest.get("HOME_POSITION")
        if home is None:
            raise FcError(f"{self._name()}: home position not known yet")
        return LLA(home.latitude / 1e7, home.longitude / 1e7, home.altitude / 1000.0)

    def velocity(self) -> NED:
        pos = self.link.latest.get("GLOBAL_POSITION_INT")
        return NED(0.0, 0.0, 0.0) if pos is None else NED(pos.vx / 100, pos.vy / 100, pos.vz / 100)

    def gps(self) -> GpsState:
        """GPS_RAW_INT's fix type (3 and better: a 3-D fix) and satellites."""
        raw = self.link.latest.get("GPS_RAW_INT")
        if raw is None:
            return GpsState(GpsFix.NO_GPS, 0)
        fix = _GPS_FIX.get(raw.fix_type, GpsFix.FIX_3D)
        hdop = raw.eph / 100.0 if raw.eph != 0xFFFF else None
        return GpsState(fix, raw.satellites_visible if raw.satellites_visible != 255 else 0, hdop)

    def wind(self) -> WindEstimate | None:
        """ArduPilot's wind estimate (its WIND message), or None from an autopilot that sends
        none (PX4 sends WIND_COV, not read here): the ground then says "unknown"."""
        wind = self.link.latest.get("WIND")
        if wind is None:
            return None
        return WindEstimate(max(0.0, float(wind.speed)), float(wind.direction) % 360.0)

    def battery(self) -> BatteryState:
        status = self.link.latest.get("SYS_STATUS")
        detail = self.link.latest.get("BATTERY_STATUS")
        cells = 0
        consumed = 0.0
        if detail is not None:
            cells = sum(1 for v in detail.voltages if v not in (0, 0xFFFF))
            consumed = max(0.0, float(detail.current_consumed))
        if status is None:
            return BatteryState(0.0, 0.0, 0.0, consumed, self._capacity_mah, cells)
        return BatteryState(
            remaining_pct=max(0.0, float(status.battery_remaining)),
            voltage_v=status.voltage_battery / 1000.0,
            current_a=max(0.0, status.current_battery / 100.0),
            consumed_mah=consumed,
            capacity_mah=self._capacity_mah,
            cell_count=cells,
        )

    def attitude(self) -> Attitude:
        att = self.link.latest.get("ATTITUDE")
        if att is None:
            return Attitude(0.0, 0.0, 0.0)
        return Attitude(
            math.degrees(att.roll), math.degrees(att.pitch), math.degrees(att.yaw) % 360.0
        )

    def state(self) -> VehicleState:
        beat = self.link.latest.get("HEARTBEAT")
        if beat is None:
            return VehicleState(False, self._arming, False, FlightMode.STABILIZE)
        mode = self._decode(beat.custom_mode)
        ext = self.link.latest.get("EXTENDED_SYS_STATE")
        if ext is not None and ext.landed_state != mav.MAV_LANDED_STATE_UNDEFINED:
            in_air = ext.landed_state in _IN_AIR_STATES
            landing = ext.landed_state == mav.MAV_LANDED_STATE_LANDING
        else:
            in_air = beat.system_status == mav.MAV_STATE_ACTIVE
            landing = in_air and mode is FlightMode.LAND
        armed = is_armed(beat)
        return VehicleState(armed, self._arming and not armed, in_air, mode, landing)

    def _decode(self, custom_mode: int) -> FlightMode:
        return decode_mode(self.autopilot, custom_mode)

    def mode_name(self) -> str:
        beat = self.link.latest.get("HEARTBEAT")
        return "UNKNOWN" if beat is None else mode_name(self.autopilot, beat.custom_mode)

    async def telemetry(self, rate_hz: float | None = None) -> AsyncIterator[dict[str, float]]:
        """Flat samples every ``1/rate_hz`` vehicle seconds until :meth:`close`."""
        period_s = 1.0 / (rate_hz or self.telemetry_rate_hz)
        while not self._closed:
            yield self.telemetry_sample()
            await self._clock.sleep(period_s)

    def telemetry_sample(self) -> dict[str, float]:
        return telemetry_sample(self, self._clock.now())  # type: ignore[arg-type]


def is_armed(beat: Message) -> bool:
    return bool(beat.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)
