"""Telemetry the simulated Copter streams, and at what rate (MAV_CMD_SET_MESSAGE_INTERVAL).

Rates are in vehicle time: a vehicle simulated 20 times faster sends 20 times more messages per wall
second, just as everything else it does happens 20 times sooner. Each builder turns the vehicle's
state into the MAVLink message an ArduPilot Copter would send (units as on the wire: 1e-7
degrees, millimetres, centimetres per second, centidegrees, millivolts, centiamps).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

from dronefleet.protocols.mavlink.codec import Message
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.protocols.mavlink.modes import CopterMode
from dronefleet.sim.gasfield import GasSensor
from dronefleet.sim.mavlink.health import sensor_bits

if TYPE_CHECKING:
    from dronefleet.sim.mavlink.copter import SimCopter

Builder = Callable[["SimCopter", GasSensor | None], Message | None]

_GUIDED_FLAG_MODES = {
    CopterMode.AUTO, CopterMode.RTL, CopterMode.LOITER, CopterMode.GUIDED, CopterMode.CIRCLE,
    CopterMode.POSHOLD, CopterMode.BRAKE, CopterMode.SMART_RTL,
}  # fmt: skip
_WALL_EPOCH_S = time.time()


def heartbeat(c: SimCopter, _: GasSensor | None) -> Message:
    v = c.vehicle
    base = (
        mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        | mav.MAV_MODE_FLAG_STABILIZE_ENABLED
        | mav.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
    )
    if c.mode in _GUIDED_FLAG_MODES:
        base |= mav.MAV_MODE_FLAG_GUIDED_ENABLED
    if v.armed:
        base |= mav.MAV_MODE_FLAG_SAFETY_ARMED
    status = mav.MAV_STATE_ACTIVE if v.in_air else mav.MAV_STATE_STANDBY
    if v.battery_failsafe:
        status = mav.MAV_STATE_CRITICAL
    return mav.MAVLink_heartbeat_message(
        mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, base, int(c.mode), status, 3
    )


def sys_status(c: SimCopter, _: GasSensor | None) -> Message:
    bat = c.vehicle.battery_state
    present, enabled, health = sensor_bits(c)
    return mav.MAVLink_sys_status_message(
        present, enabled, health, 200,
        round(bat.voltage_v * 1000), round(bat.current_a * 100), round(bat.remaining_pct),
        0, 0, 0, 0, 0, 0,
    )  # fmt: skip


def battery_status(c: SimCopter, _: GasSensor | None) -> Message:
    bat = c.vehicle.battery_state
    cell_mv = round(bat.voltage_v * 1000 / bat.cell_count)
    cells = [cell_mv] * bat.cell_count + [0xFFFF] * (10 - bat.cell_count)
    return mav.MAVLink_battery_status_message(
        0, mav.MAV_BATTERY_FUNCTION_ALL, mav.MAV_BATTERY_TYPE_LIPO, 0x7FFF, cells[:10],
        round(bat.current_a * 100), round(bat.consumed_mah), -1, round(bat.remaining_pct),
    )  # fmt: skip


def global_position_int(c: SimCopter, _: GasSensor | None) -> Message:
    v = c.vehicle
    pos, vel = v.position_lla, v.velocity_ned
    return mav.MAVLink_global_position_int_message(
        c.boot_ms(), round(pos.lat * 1e7), round(pos.lon * 1e7), round(pos.alt_m * 1000),
        round(v.relative_alt_m * 1000), round(vel.n * 100), round(vel.e * 100),
        round(vel.d * 100), round(v.attitude.yaw_deg * 100) % 36000,
    )  # fmt: skip


def local_position_ned(c: SimCopter, _: GasSensor | None) -> Message:
    """Position and velocity from the EKF origin (home here), metres and m/s, as ArduPilot sends
    it in the POSITION stream beside GLOBAL_POSITION_INT."""
    v = c.vehicle
    pos, vel = v.position_ned, v.velocity_ned
    return mav.MAVLink_local_position_ned_message(
        c.boot_ms(), pos.n, pos.e, pos.d, vel.n, vel.e, vel.d
    )


def attitude(c: SimCopter, _: GasSensor | None) -> Message:
    att = c.vehicle.attitude
    yaw = math.radians(att.yaw_deg)
    yaw = yaw - 2 * math.pi if yaw > math.pi else yaw
    return mav.MAVLink_attitude_message(
        c.boot_ms(), math.radians(att.roll_deg), math.radians(att.pitch_deg), yaw, 0, 0, 0
    )


def gps_raw_int(c: SimCopter, _: GasSensor | None) -> Message:
    v = c.vehicle
    fix, vel = v.gps_lla, v.velocity_ned
    cog = math.degrees(math.atan2(vel.e, vel.n)) % 360.0
    return mav.MAVLink_gps_raw_int_message(
        round(max(v.gps.fix_time_s - c.boot_epoch_s, 0) * 1e6), mav.GPS_FIX_TYPE_3D_FIX,
        round(fix.lat * 1e7), round(fix.lon * 1e7), round(fix.alt_m * 1000),
        round(v.gps.hdop * 100), round(v.gps.hdop * 150), round(vel.horizontal_m * 100),
        round(cog * 100) % 36000, v.gps.satellites,
    )  # fmt: skip


def home_position(c: SimCopter, _: GasSensor | None) -> Message:
    home = c.vehicle.home
    return mav.MAVLink_home_position_message(
        round(home.lat * 1e7), round(home.lon * 1e7), round(home.alt_m * 1000),
        0, 0, 0, [1, 0, 0, 0], 0, 0, 0, c.boot_ms() * 1000,
    )  # fmt: skip


def system_time(c: SimCopter, _: GasSensor | None) -> Message:
    unix_us = round((_WALL_EPOCH_S + c.vehicle.time_s) * 1e6)
    return mav.MAVLink_system_time_message(unix_us, c.boot_ms())


def extended_sys_state(c: SimCopter, _: GasSensor | None) -> Message:
    v = c.vehicle
    if not v.in_air:
        landed = mav.MAV_LANDED_STATE_ON_GROUND
    elif v.landing or v.falling:
        landed = mav.MAV_LANDED_STATE_LANDING
    elif v.velocity_ned.d < -0.2 and v.relative_alt_m < 2.0:
        landed = mav.MAV_LANDED_STATE_TAKEOFF
    else:
        landed = mav.MAV_LANDED_STATE_IN_AIR
    return mav.MAVLink_extended_sys_state_message(mav.MAV_VTOL_STATE_UNDEFINED, landed)


def mission_current(c: SimCopter, _: GasSensor | None) -> Message:
    runner = c.runner
    total = max(len(c.mission) - 1, 0)
    if not c.mission or len(c.mission) <= 1:
        state = mav.MISSION_STATE_NO_MISSION
    elif runner.finished:
        state = mav.MISSION_STATE_COMPLETE
    elif runner.running:
        state = mav.MISSION_STATE_ACTIVE
    else:
        state = mav.MISSION_STATE_NOT_STARTED
    return mav.MAVLink_mission_current_message(runner.current, total, state, 0)


def vfr_hud(c: SimCopter, _: GasSensor | None) -> Message:
    v = c.vehicle
    vel = v.velocity_ned
    throttle = 50 if v.in_air else 0
    return mav.MAVLink_vfr_hud_message(
        vel.horizontal_m, vel.horizontal_m, round(v.attitude.yaw_deg) % 360, throttle,
        v.position_lla.alt_m, -vel.d,
    )  # fmt: skip


def co2(c: SimCopter, sensor: GasSensor | None) -> Message | None:
    if sensor is None:
        return None
    return mav.MAVLink_named_value_float_message(c.boot_ms(), b"CO2", sensor.read().value)


def position_target(c: SimCopter, _: GasSensor | None) -> Message | None:
    target = c.vehicle.target_ned
    if target is None or c.mode is not CopterMode.GUIDED:
        return None
    from dronefleet.geo.ned import ned_to_lla

    lla = ned_to_lla(target, c.vehicle.home)
    return mav.MAVLink_position_target_global_int_message(
        c.boot_ms(), mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 0x0DF8,
        round(lla.lat * 1e7), round(lla.lon * 1e7), -target.d, 0, 0, 0, 0, 0, 0, 0, 0,
    )  # fmt: skip


BUILDERS: dict[int, Builder] = {
    mav.MAVLINK_MSG_ID_HEARTBEAT: heartbeat,
    mav.MAVLINK_MSG_ID_SYS_STATUS: sys_status,
    mav.MAVLINK_MSG_ID_BATTERY_STATUS: battery_status,
    mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: global_position_int,
    mav.MAVLINK_MSG_ID_LOCAL_POSITION_NED: local_position_ned,
    mav.MAVLINK_MSG_ID_ATTITUDE: attitude,
    mav.MAVLINK_MSG_ID_GPS_RAW_INT: gps_raw_int,
    mav.MAVLINK_MSG_ID_HOME_POSITION: home_position,
    mav.MAVLINK_MSG_ID_SYSTEM_TIME: system_time,
    mav.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: extended_sys_state,
    mav.MAVLINK_MSG_ID_MISSION_CURRENT: mission_current,
    mav.MAVLINK_MSG_ID_VFR_HUD: vfr_hud,
    mav.MAVLINK_MSG_ID_NAMED_VALUE_FLOAT: co2,
    mav.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT: position_target,
}

#: Default intervals (vehicle seconds), as a freshly booted Copter sends them on its GCS port.
DEFAULT_INTERVALS_S: dict[int, float] = {
    mav.MAVLINK_MSG_ID_HEARTBEAT: 1.0,
    mav.MAVLINK_MSG_ID_SYS_STATUS: 1.0,
    mav.MAVLINK_MSG_ID_BATTERY_STATUS: 1.0,
    mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 0.25,
    mav.MAVLINK_MSG_ID_LOCAL_POSITION_NED: 0.25,
    mav.MAVLINK_MSG_ID_ATTITUDE: 0.25,
    mav.MAVLINK_MSG_ID_GPS_RAW_INT: 0.5,
    mav.MAVLINK_MSG_ID_HOME_POSITION: 5.0,
    mav.MAVLINK_MSG_ID_SYSTEM_TIME: 1.0,
    mav.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: 1.0,
    mav.MAVLINK_MSG_ID_MISSION_CURRENT: 1.0,
    mav.MAVLINK_MSG_ID_VFR_HUD: 1.0,
    mav.MAVLINK_MSG_ID_NAMED_VALUE_FLOAT: 0.5,
    mav.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT: 1.0,
}

#: REQUEST_DATA_STREAM groups (the legacy way ArduPilot ground stations still ask).
DATA_STREAMS: dict[int, tuple[int, ...]] = {
    mav.MAV_DATA_STREAM_EXTENDED_STATUS: (
        mav.MAVLINK_MSG_ID_SYS_STATUS, mav.MAVLINK_MSG_ID_GPS_RAW_INT,
        mav.MAVLINK_MSG_ID_MISSION_CURRENT, mav.MAVLINK_MSG_ID_BATTERY_STATUS,
    ),
    mav.MAV_DATA_STREAM_POSITION: (
        mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, mav.MAVLINK_MSG_ID_LOCAL_POSITION_NED,
    ),
    mav.MAV_DATA_STREAM_EXTRA1: (mav.MAVLINK_MSG_ID_ATTITUDE,),
    mav.MAV_DATA_STREAM_EXTRA2: (mav.MAVLINK_MSG_ID_VFR_HUD,),
    mav.MAV_DATA_STREAM_EXTRA3: (mav.MAVLINK_MSG_ID_SYSTEM_TIME,),
}  # fmt: skip


class StreamScheduler:
    """Which messages are due at a vehicle time, with per-message intervals."""

    def __init__(self) -> None:
        self.intervals_s = dict(DEFAULT_INTERVALS_S)
        self._next: dict[int, float] = {}

    def reset(self) -> None:
        self.intervals_s = dict(DEFAULT_INTERVALS_S)
        self._next.clear()

    def set_interval(self, msg_id: int, interval_us: float) -> bool:
        """SET_MESSAGE_INTERVAL semantics: -1 stops, 0 restores the default."""
        if msg_id not in BUILDERS:
            return False
        if interval_us < 0:
            self.intervals_s.pop(msg_id, None)
        elif interval_us == 0:
            self.intervals_s[msg_id] = DEFAULT_INTERVALS_S[msg_id]
        else:
            self.intervals_s[msg_id] = max(interval_us / 1e6, 0.01)
        self._next.pop(msg_id, None)
        return True

    def interval_us(self, msg_id: int) -> int:
        interval = self.intervals_s.get(msg_id)
        return -1 if interval is None else round(interval * 1e6)

    def request_data_stream(self, stream_id: int, rate_hz: int, start: bool) -> None:
        groups = DATA_STREAMS.values() if stream_id == mav.MAV_DATA_STREAM_ALL else [
            DATA_STREAMS.get(stream_id, ())
        ]  # fmt: skip
        for group in groups:
            for msg_id in group:
                self.set_interval(msg_id, 1e6 / rate_hz if start and rate_hz > 0 else -1)

    def due(self, now_s: float) -> list[int]:
        out = []
        for msg_id, interval in self.intervals_s.items():
            at = self._next.get(msg_id)
            if at is None or now_s >= at - 1e-9:
                out.append(msg_id)
                # Stay on the grid; after a stall, restart from now instead of bursting.
                at = now_s if at is None or now_s - at > interval else at
                self._next[msg_id] = at + interval
        return out
