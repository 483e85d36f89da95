"""SYS_STATUS's sensor bits as ArduPilot Copter sets them (issue 10, item 2).

A healthy Copter reports its gyros, accelerometers, compass, barometer, GPS, AHRS, battery monitor
and logging present, enabled and healthy (``GCS::update_sensor_status_flags``), the rate, attitude
and yaw controllers always on, the altitude and position controllers present and enabled only in
the modes that use them, the motor outputs present (``GCS_Copter::update_vehicle_sensor_status_
flags``), and MAV_SYS_STATUS_PREARM_CHECK present, enabled while ARMING_CHECK is not zero and
healthy while the pre-arm checks pass (``AP_Arming``: MAVSDK's ``health.is_armable``). The geofence
(``AC_Fence::sys_status_*``) is present when FENCE_TYPE names a fence, enabled when FENCE_ENABLE
is set and FENCE_ACTION is not report-only, and healthy unless breached: a fence that is not there
is not failing, which is why MAVProxy said "fence breach" when the health bit was missing.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.protocols.mavlink.modes import CopterMode

if TYPE_CHECKING:
    from dronefleet.sim.mavlink.copter import SimCopter

_ALWAYS = (
    mav.MAV_SYS_STATUS_SENSOR_3D_GYRO
    | mav.MAV_SYS_STATUS_SENSOR_3D_ACCEL
    | mav.MAV_SYS_STATUS_SENSOR_3D_MAG
    | mav.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
    | mav.MAV_SYS_STATUS_AHRS
    | mav.MAV_SYS_STATUS_LOGGING
    | mav.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL
    | mav.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION
    | mav.MAV_SYS_STATUS_SENSOR_YAW_POSITION
)
_Z = mav.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL
_XY = mav.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
_MOTORS = mav.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
_GPS = mav.MAV_SYS_STATUS_SENSOR_GPS
_BATTERY = mav.MAV_SYS_STATUS_SENSOR_BATTERY
_FENCE = mav.MAV_SYS_STATUS_GEOFENCE
_PREARM = mav.MAV_SYS_STATUS_PREARM_CHECK
_TERRAIN = mav.MAV_SYS_STATUS_TERRAIN

#: Modes with automatic altitude and position control (the rest are manual or altitude only).
_POSITION_MODES = {
    CopterMode.AUTO, CopterMode.GUIDED, CopterMode.RTL, CopterMode.SMART_RTL, CopterMode.LOITER,
    CopterMode.POSHOLD, CopterMode.CIRCLE, CopterMode.BRAKE, CopterMode.LAND,
}  # fmt: skip
_ALTITUDE_MODES = {CopterMode.ALT_HOLD, CopterMode.SPORT, CopterMode.GUIDED_NOGPS}
_FENCE_TYPES = 0b1111  # ALT_MAX, CIRCLE, POLYGON, ALT_MIN
_FENCE_REPORT_ONLY = 0


def prearm_failure(copter: SimCopter) -> str | None:
    """Why the pre-arm checks fail now (None: they pass), as ArduPilot's "PreArm: …" says it."""
    v = copter.vehicle
    if copter.params.get("ARMING_CHECK") == 0:
        return None
    if v.rebooting:
        return "Waiting for RC"  # not booted yet
    if v.battery_state.remaining_pct <= v.failsafe_pct:
        return "Battery 1 below minimum"
    if v.gps.satellites < 6:
        return "GPS 1: not enough satellites"
    if fence_breached(copter):
        return "Fence: vehicle outside the fence"
    return None


def fence_breached(copter: SimCopter) -> bool:
    """Outside an enabled circle or altitude fence (FENCE_RADIUS, FENCE_ALT_MAX, metres)."""
    p = copter.params
    if not p.get("FENCE_ENABLE"):
        return False
    kinds = int(p.get("FENCE_TYPE"))
    v = copter.vehicle
    here = v.position_ned
    outside_circle = kinds & 2 and (here.n**2 + here.e**2) ** 0.5 > p.get("FENCE_RADIUS")
    too_high = kinds & 1 and v.relative_alt_m > p.get("FENCE_ALT_MAX")
    return bool(outside_circle or too_high)


def sensor_bits(copter: SimCopter) -> tuple[int, int, int]:
    """(present, enabled, health) for SYS_STATUS."""
    p, v = copter.params, copter.vehicle
    present = enabled = health = _ALWAYS
    present |= _Z | _XY | _MOTORS | _GPS
    if copter.mode in _POSITION_MODES:
        enabled |= _Z | _XY
    elif copter.mode in _ALTITUDE_MODES:
        enabled |= _Z
    enabled |= _MOTORS | _GPS  # no safety switch in the sim (BRD_SAFETY_DEFLT 0)
    health |= _Z | _XY | _MOTORS | _GPS
    if p.get("BATT_MONITOR") != 0:
        present |= _BATTERY
        enabled |= _BATTERY
        if not v.battery_failsafe:
            health |= _BATTERY
    if p.get("TERRAIN_ENABLE") != 0:  # flat ground everywhere: the terrain data is all there
        present |= _TERRAIN
        enabled |= _TERRAIN
        health |= _TERRAIN
    if int(p.get("FENCE_TYPE")) & _FENCE_TYPES:
        present |= _FENCE
        if p.get("FENCE_ENABLE") and p.get("FENCE_ACTION") != _FENCE_REPORT_ONLY:
            enabled |= _FENCE
    if not fence_breached(copter):
        health |= _FENCE
    present |= _PREARM
    if p.get("ARMING_CHECK") != 0:
        enabled |= _PREARM
    if copter.prearm_passed:
        health |= _PREARM
    return present, enabled, health
