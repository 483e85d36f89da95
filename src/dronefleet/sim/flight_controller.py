"""The ``sim`` flight-controller backend: the FlightController protocol over an in-process
:class:`~dronefleet.sim.vehicle.SimVehicle`.

This is what the Drone Controller talks to when no real autopilot is attached (docs/DESIGN.md §5).
Commands go straight to the vehicle; waiting (arming, reboot, telemetry rate) is on the sim clock,
so it runs as fast as the :class:`~dronefleet.sim.world.SimWorld` loop drives it. Raw object
requests answer with dRonin UAVObject names (the seed's Flight Controller, section 4.1.2.1).
"""

from __future__ import annotations

import math
from collections.abc import AsyncIterator, Callable
from typing import Any

from dronefleet.geo.ned import lla_to_ned
from dronefleet.geo.types import LLA, NED
from dronefleet.sim.clock import SimClock
from dronefleet.sim.vehicle import SimVehicle
from dronefleet.vehicle.base import (
    Attitude,
    BatteryState,
    FcError,
    GpsFix,
    GpsState,
    VehicleState,
    WindEstimate,
)
from dronefleet.vehicle.kinematics import GRAVITY_MPS2
from dronefleet.vehicle.views import flight_battery_state

#: How often waits on the vehicle look at it again (vehicle seconds; one physics step).
_POLL_S = 0.05


class SimFlightController:
    """FlightController for a simulated vehicle; needs its world loop running to make progress."""

    def __init__(
        self, vehicle: SimVehicle, clock: SimClock, *, telemetry_rate_hz: float = 5.0
    ) -> None:
        if telemetry_rate_hz <= 0:
            raise ValueError("telemetry rate must be positive")
        self.vehicle = vehicle
        self._clock = clock
        self.telemetry_rate_hz = telemetry_rate_hz
        self._closed = False
        self._objects: dict[str, Callable[[], dict[str, Any]]] = {
            "GPSPosition": self._gps_position,
            "AttitudeActual": self._attitude_actual,
            "FlightStatus": self._flight_status,
            "FlightBatteryState": self._flight_battery_state,
            "PositionActual": lambda: _ned_dict(vehicle.position_ned),
            "VelocityActual": lambda: _ned_dict(vehicle.velocity_ned),
            "Accels": self._accels,
            "HomeLocation": self._home_location,
        }

    @property
    def clock(self) -> SimClock:
        return self._clock

    async def connect(self) -> None:
        self._closed = False

    async def close(self) -> None:
        self._closed = True

    # -- commands -----------------------------------------------------------------------------
    async def arm(self) -> None:
        self.vehicle.arm()
        while self.vehicle.arming:
            await self._clock.sleep(_POLL_S)
        if not self.vehicle.armed:
            raise FcError(f"{self.vehicle.vehicle_id}: arming was interrupted")

    async def disarm(self, *, force: bool = False) -> None:
        self.vehicle.disarm(force=force)

    async def takeoff(self, altitude_m: float) -> None:
        self.vehicle.takeoff(altitude_m)

    async def land(self) -> None:
        self.vehicle.land()

    async def goto(self, target: LLA) -> None:
        home = self.vehicle.home
        if target.alt_m < home.alt_m:
            raise FcError(
                f"{self.vehicle.vehicle_id}: target altitude {target.alt_m:.1f} m AMSL is below"
                f" home ({home.alt_m:.1f} m AMSL)"
            )
        self.vehicle.goto(lla_to_ned(target, home))

    def flight_params(self) -> dict[str, float]:
        """How the simulated vehicle flies (for the planner's estimates)."""
        limits, battery = self.vehicle.limits, self.vehicle.battery
        return {
            "speed_mps": limits.max_speed_mps,
            "accel_mps2": limits.accel_mps2,
            "climb_mps": limits.max_climb_mps,
            "descent_mps": limits.max_descent_mps,
            "capacity_mah": battery.capacity_mah,
            "hover_current_a": battery.hover_current_a,
        }

    async def hold(self) -> None:
        self.vehicle.hold()

    def takeover_cause(self) -> str | None:
        """Why the vehicle changed its mode itself, if it did (drone/takeover.py)."""
        return "battery failsafe: landing" if self.vehicle.battery_failsafe else None

    async def reboot(self, *, force: bool = False) -> None:
        """Restart the autopilot; returns once it is back (about 2 vehicle seconds). Refused in
        the air unless ``force`` (then the motors stop and the vehicle falls)."""
        self.vehicle.reboot(force=force)
        while self.vehicle.rebooting:
            await self._clock.sleep(_POLL_S)

    async def rebuild_telemetry(self) -> None:
        """Nothing to rebuild: the sim's telemetry is computed from the vehicle on demand."""

    async def request_object(self, name: str) -> dict[str, Any]:
        build = self._objects.get(name)
        if build is None:
            raise FcError(f"unknown object {name!r}; known: {', '.join(sorted(self._objects))}")
        return build()

    # -- latest state -------------------------------------------------------------------------
    def position(self) -> LLA:
        """The latest GPS fix (5 Hz)."""
        return self.vehicle.gps_lla

    def home(self) -> LLA:
        return self.vehicle.home

    def velocity(self) -> NED:
        return self.vehicle.velocity_ned

    def gps(self) -> GpsState:
        """The simulated receiver: a 3-D fix from its first sample, with its satellites."""
        receiver = self.vehicle.gps
        fix = GpsFix.FIX_3D if receiver.fix_count > 0 else GpsFix.NO_FIX
        return GpsState(fix, receiver.satellites if fix.usable else 0, receiver.hdop)

    def wind(self) -> WindEstimate:
        """The wind the vehicle flies in, as an autopilot's estimate of it (ArduPilot's WIND):
        the simulated world's own, so calm when it is calm."""
        wind = self.vehicle.wind
        return WindEstimate(wind.speed_mps, wind.from_deg)

    def battery(self) -> BatteryState:
        return self.vehicle.battery_state

    def attitude(self) -> Attitude:
        return self.vehicle.attitude

    def state(self) -> VehicleState:
        v = self.vehicle
        return VehicleState(
            armed=v.armed, arming=v.arming, in_air=v.in_air, mode=v.mode, landing=v.landing
        )

    async def telemetry(self, rate_hz: float | None = None) -> AsyncIterator[dict[str, float]]:
        """Flat samples every ``1/rate_hz`` vehicle seconds (default ``telemetry_rate_hz``)
        until :meth:`close`."""
        period_s = 1.0 / (rate_hz or self.telemetry_rate_hz)
        while not self._closed:
            yield self.telemetry_sample()
            await self._clock.sleep(period_s)

    def telemetry_sample(self) -> dict[str, float]:
        """:func:`~dronefleet.vehicle.base.telemetry_sample` of this controller (the vehicle
        builds it from its state, figure for figure)."""
        return self.vehicle.telemetry_sample()

    # -- UAVObject-like views (floats in SI units; lat/lon in degrees) -------------------------
    def _gps_position(self) -> dict[str, Any]:
        v = self.vehicle
        fix, vel = v.gps_lla, v.velocity_ned
        return {
            "Latitude": fix.lat,
            "Longitude": fix.lon,
            "Altitude": fix.alt_m,
            "Groundspeed": vel.horizontal_m,
            "Heading": math.degrees(math.atan2(vel.e, vel.n)) % 360.0,
            "Satellites": v.gps.satellites,
            "HDOP": v.gps.hdop,
            "Status": "Fix3D",
            "FixTime": v.gps.fix_time_s,
        }

    def _attitude_actual(self) -> dict[str, Any]:
        att = self.vehicle.attitude
        return {"Roll": att.roll_deg, "Pitch": att.pitch_deg, "Yaw": att.yaw_deg}

    def _flight_status(self) -> dict[str, Any]:
        v = self.vehicle
        armed = "Armed" if v.armed else "Arming" if v.arming else "Disarmed"
        return {
            "Armed": armed,
            "FlightMode": v.mode.value,
            "InAir": v.in_air,
            "Landing": v.landing,
            "Rebooting": v.rebooting,
        }

    def _flight_battery_state(self) -> dict[str, Any]:
        return flight_battery_state(self.vehicle.battery_state)

    def _accels(self) -> dict[str, Any]:
        """Specific force in the body frame (m/s²): a multirotor feels thrust only, along -z."""
        v = self.vehicle
        if not v.in_air:
            return {"x": 0.0, "y": 0.0, "z": -GRAVITY_MPS2}
        acc = v.acceleration_ned
        thrust = math.sqrt(acc.n * acc.n + acc.e * acc.e + (acc.d - GRAVITY_MPS2) ** 2)
        return {"x": 0.0, "y": 0.0, "z": 0.0 if v.falling else -thrust}

    def _home_location(self) -> dict[str, Any]:
        home = self.vehicle.home
        return {"Latitude": home.lat, "Longitude": home.lon, "Altitude": home.alt_m, "Set": True}


def _ned_dict(ned: NED) -> dict[str, Any]:
    return {"North": ned.n, "East": ned.e, "Down": ned.d}
