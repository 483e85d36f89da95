"""What a drone says without being asked: heartbeats, alarms, telemetry."""

from __future__ import annotations

from enum import StrEnum
from typing import Any

from pydantic import Field

from dronefleet.messaging.commands import AlarmLevel
from dronefleet.messaging.common import DroneId, Message, Position, wall_time
from dronefleet.vehicle.base import GpsFix


class FlightState(StrEnum):
    DISARMED = "disarmed"
    ARMING = "arming"
    ARMED = "armed"  # armed, on the ground
    TAKING_OFF = "taking_off"
    FLYING = "flying"
    LANDING = "landing"


class BatteryStatus(Message):
    remaining_pct: float = Field(ge=0, le=100)
    voltage_v: float = Field(ge=0)
    current_a: float | None = None
    consumed_mah: float | None = None


class FlightParams(Message):
    """How this vehicle flies, for the planner's time and battery estimates (issue 17): its
    autopilot's settings (ArduPilot: WP_SPD, WP_ACC, WP_ACC_Z, WP_JERK, WP_SPD_UP/DN,
    LAND_SPD_MS, LAND_ALT_LOW_M, BATT_CAPACITY) and the current it draws: known (the simulator's
    model) or measured in flight (drone/draw.py)."""

    speed_mps: float | None = Field(default=None, gt=0, le=50)
    accel_mps2: float | None = Field(default=None, gt=0, le=20)
    accel_z_mps2: float | None = Field(default=None, gt=0, le=20)
    jerk_mps3: float | None = Field(default=None, gt=0, le=100)
    climb_mps: float | None = Field(default=None, gt=0, le=20)
    descent_mps: float | None = Field(default=None, gt=0, le=20)
    land_speed_mps: float | None = Field(default=None, gt=0, le=20)
    land_alt_low_m: float | None = Field(default=None, ge=0, le=100)
    capacity_mah: float | None = Field(default=None, gt=0, le=1_000_000)
    # How its autopilot flies home (issue 28): ArduPilot's RTL_ALT, RTL_SPEED, RTL_ALT_FINAL,
    # RTL_LOIT_TIME, RTL_CONE_SLOPE, RTL_CLIMB_MIN and LAND_SPEED_HIGH (PX4: RTL_RETURN_ALT,
    # RTL_LAND_DELAY), so the planner's estimate of the way home uses the vehicle's own values.
    # Zero is a setting for the ``ge=0`` ones (no loiter, no cone, land at the end).
    land_speed_high_mps: float | None = Field(default=None, gt=0, le=20)
    rtl_alt_m: float | None = Field(default=None, gt=0, le=1_000)
    rtl_speed_mps: float | None = Field(default=None, gt=0, le=50)
    rtl_alt_final_m: float | None = Field(default=None, ge=0, le=1_000)
    rtl_loiter_s: float | None = Field(default=None, ge=0, le=3_600)
    rtl_cone_slope: float | None = Field(default=None, ge=0, le=10)
    rtl_climb_min_m: float | None = Field(default=None, ge=0, le=1_000)
    #: A vehicle whose draw is known (our simulator) says so; any other is measured in flight.
    hover_current_a: float | None = Field(default=None, gt=0, le=1000)
    flight_current_a: float | None = Field(default=None, gt=0, le=1000)


class GpsStatus(Message):
    """The GPS receiver's fix and satellites, for the pre-flight check (issue 14)."""

    fix: GpsFix
    satellites: int = Field(ge=0, le=255)
    hdop: float | None = Field(default=None, ge=0, le=100)


class WindStatus(Message):
    """The wind the autopilot estimates; absent from a heartbeat when it estimates none."""

    speed_mps: float = Field(ge=0, le=100)
    from_deg: float = Field(ge=0, le=360)


class LinkFailsafe(Message):
    """What the autopilot does by itself when the drone's software falls silent: its GCS
    failsafe (ArduPilot FS_GCS_ENABLE/FS_GCS_TIMEOUT, PX4 NAV_DLL_ACT/COM_DL_LOSS_T; issue 26,
    drone/fc/mavlink/gcs_failsafe.py). Absent from a heartbeat when the backend has none."""

    action: str = Field(min_length=1, max_length=40, description='"off", "rtl", "land", ...')
    timeout_s: float | None = Field(default=None, ge=0, le=3600)
    set_by_drone: bool = False


class Heartbeat(Message):
    """Sent every 5 s (vehicle time) on ``<id>/heartbeats/out``."""

    drone_id: DroneId
    timestamp: float = Field(default_factory=wall_time)
    vehicle_time_s: float
    interval_s: float = Field(
        default=5.0, gt=0, le=3600, description="vehicle seconds to the next heartbeat"
    )
    position: Position
    home: Position | None = None
    battery: BatteryStatus
    state: FlightState
    mode: str
    mission_id: str | None = None
    step_index: int | None = None
    autopilot_link: bool = Field(
        default=True, description="the drone's link to its flight controller is up"
    )
    flight: FlightParams | None = None
    ground_speed_mps: float | None = Field(default=None, ge=0, le=200)
    gps: GpsStatus | None = None
    wind: WindStatus | None = None
    link_failsafe: LinkFailsafe | None = None


class Alarm(Message):
    """Sent once per crossing on ``<id>/alarms/out``."""

    drone_id: DroneId
    level: AlarmLevel
    message: str = ""
    position: Position
    reading: dict[str, Any] | None = None
    mission_id: str | None = None
    step_index: int | None = None
    virtual: bool = False
    vehicle_time_s: float
    timestamp: float = Field(default_factory=wall_time)


class Telemetry(Message):
    """Numeric flight data on ``<id>/telemetry/out`` (a flat field map, ready for a time series)."""

    drone_id: DroneId
    timestamp: float = Field(default_factory=wall_time)
    vehicle_time_s: float
    fields: dict[str, float]
