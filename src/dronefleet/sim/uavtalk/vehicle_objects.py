"""A simulated vehicle seen as a dRonin board's UAVObjects (seed 4.1.2.1).

:class:`VehicleObjects` is the flight side of the UAVTalk simulator for one
:class:`~dronefleet.sim.vehicle.SimVehicle`: it builds the objects a dRonin flight controller
would publish (GPSPosition, AttitudeActual, FlightStatus, PositionActual, VelocityActual, Accels,
FlightBatteryState, HomeLocation, SystemStats) and carries out what the ground writes:

* ``Waypoint`` — a target in metres north, east and down of HomeLocation (seed Figure 4.13: dRonin
  takes waypoints in NED only); the vehicle flies to it. Every instance written is kept so it can
  be read back;
* ``FlightCommand`` — our stand-in for the seed's stick emulator (arming, 4.1.2.4) and for the
  Navigation Processor's take-off and landing requests.

A refusal raises :class:`~dronefleet.sim.vehicle.VehicleError` with the vehicle's reason.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from dronefleet.geo.types import NED
from dronefleet.protocols.uavtalk.objects import ObjectDef
from dronefleet.protocols.uavtalk.registry import ObjectRegistry
from dronefleet.sim.vehicle import SimVehicle, VehicleError
from dronefleet.vehicle.kinematics import GRAVITY_MPS2
from dronefleet.vehicle.views import flight_battery_state

_ACCEL_TEMPERATURE_C = 35.0


class VehicleObjects:
    """The UAVObjects of one simulated vehicle, in SI units (see ``ObjectDef.from_si``)."""

    def __init__(self, vehicle: SimVehicle, registry: ObjectRegistry) -> None:
        self.vehicle = vehicle
        self.registry = registry
        self.waypoints: dict[int, dict[str, Any]] = {}
        self._builders: dict[str, Callable[[], dict[str, Any]]] = {
            "GPSPosition": self._gps_position,
            "AttitudeActual": self._attitude_actual,
            "FlightStatus": self._flight_status,
            "PositionActual": lambda: _ned(vehicle.position_ned),
            "VelocityActual": lambda: _ned(vehicle.velocity_ned),
            "Accels": self._accels,
            "FlightBatteryState": self._flight_battery_state,
            "HomeLocation": self._home_location,
            "SystemStats": self._system_stats,
        }

    def served(self) -> list[ObjectDef]:
        """The objects this vehicle publishes (those with a definition in the registry)."""
        return [self.registry[name] for name in self._builders if name in self.registry]

    def values(self, name: str, instance: int = 0) -> dict[str, Any] | None:
        """Wire values of an object instance, or None if the vehicle has no such object."""
        definition = self.registry.by_name.get(name)
        if definition is None:
            return None
        if name == "Waypoint":
            return self.waypoints.get(instance)
        build = self._builders.get(name)
        if build is None or instance != 0:
            return None
        return definition.from_si(build())

    def packed(self, name: str, instance: int = 0) -> bytes | None:
        values = self.values(name, instance)
        return None if values is None else self.registry[name].encode(values)

    # -- writes --------------------------------------------------------------------------------
    def apply(self, name: str, instance: int, values: dict[str, Any]) -> None:
        """Carry out a write from the ground; raises VehicleError when the vehicle refuses."""
        vid = self.vehicle.vehicle_id
        if name == "Waypoint":
            self._fly_waypoint(values)
            self.waypoints[instance] = values
        elif name == "FlightCommand":
            self._command(values)
        else:
            raise VehicleError(f"{vid}: {name} is read-only on the flight controller")

    def _fly_waypoint(self, values: dict[str, Any]) -> None:
        v = self.vehicle
        pos = values["Position"]
        target = NED(pos["North"], pos["East"], pos["Down"])
        if not all(math.isfinite(x) for x in (target.n, target.e, target.d)):
            raise VehicleError(f"{v.vehicle_id}: waypoint {target} is not a finite position")
        match values["Mode"]:
            case "FlyEndpoint":
                v.goto(target)
            case "Hold":
                v.hold()
            case "Land":
                v.land()
            case other:
                raise VehicleError(f"{v.vehicle_id}: waypoint mode {other!r} is not supported")

    def _command(self, values: dict[str, Any]) -> None:
        v, force = self.vehicle, values["Force"] == "True"
        match values["Command"]:
            case "None":
                pass
            case "Arm":
                v.arm()
            case "Disarm":
                v.disarm(force=force)
            case "Takeoff":
                v.takeoff(values["Altitude"])
            case "Land":
                v.land()
            case "Hold":
                v.hold()
            case "Reboot":
                v.reboot(force=force)
            case other:
                raise VehicleError(f"{v.vehicle_id}: unknown flight command {other!r}")

    # -- the objects ---------------------------------------------------------------------------
    def _gps_position(self) -> dict[str, Any]:
        v = self.vehicle
        fix, vel = v.gps_lla, v.velocity_ned
        return {
            "Status": "Fix3D",
            "Latitude": fix.lat,
            "Longitude": fix.lon,
            "Altitude": fix.alt_m,
            "GeoidSeparation": 0.0,
            "Heading": math.degrees(math.atan2(vel.e, vel.n)) % 360.0,
            "Groundspeed": vel.horizontal_m,
            "Satellites": v.gps.satellites,
            "PDOP": v.gps.hdop * 1.5,
            "HDOP": v.gps.hdop,
            "VDOP": v.gps.hdop * 1.2,
            "FixTime": v.gps.fix_time_s,
        }

    def _attitude_actual(self) -> dict[str, Any]:
        att = self.vehicle.attitude
        q = _quaternion(att.roll_deg, att.pitch_deg, att.yaw_deg)
        return {
            "q1": q[0],
            "q2": q[1],
            "q3": q[2],
            "q4": q[3],
            "Roll": att.roll_deg,
            "Pitch": att.pitch_deg,
            "Yaw": att.yaw_deg,
        }

    def _flight_status(self) -> dict[str, Any]:
        v = self.vehicle
        return {
            "Armed": "Armed" if v.armed else "Arming" if v.arming else "Disarmed",
            "FlightMode": v.mode.value,
            "InAir": v.in_air,
            "Landing": v.landing,
            "Rebooting": v.rebooting,
        }

    def _accels(self) -> dict[str, Any]:
        """Specific force in the body frame: a multirotor feels its thrust only, along -z."""
        v = self.vehicle
        z = -GRAVITY_MPS2
        if v.falling:
            z = 0.0
        elif v.in_air:
            acc = v.acceleration_ned
            z = -math.sqrt(acc.n * acc.n + acc.e * acc.e + (acc.d - GRAVITY_MPS2) ** 2)
        return {"x": 0.0, "y": 0.0, "z": z, "temperature": _ACCEL_TEMPERATURE_C}

    def _flight_battery_state(self) -> dict[str, Any]:
        return flight_battery_state(self.vehicle.battery_state)

    def _home_location(self) -> dict[str, Any]:
        home = self.vehicle.home
        return {"Set": True, "Latitude": home.lat, "Longitude": home.lon, "Altitude": home.alt_m}

    def _system_stats(self) -> dict[str, Any]:
        return {"FlightTime": int(self.vehicle.time_s * 1000.0) & 0xFFFFFFFF, "CPULoad": 20}


def _ned(ned: NED) -> dict[str, float]:
    return {"North": ned.n, "East": ned.e, "Down": ned.d}


def _quaternion(roll_deg: float, pitch_deg: float, yaw_deg: float) -> tuple[float, ...]:
    """Body-to-NED rotation (yaw, pitch, roll order) as (w, x, y, z)."""
    cr, sr = math.cos(math.radians(roll_deg) / 2), math.sin(math.radians(roll_deg) / 2)
    cp, sp = math.cos(math.radians(pitch_deg) / 2), math.sin(math.radians(pitch_deg) / 2)
    cy, sy = math.cos(math.radians(yaw_deg) / 2), math.sin(math.radians(yaw_deg) / 2)
    return (
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    )
