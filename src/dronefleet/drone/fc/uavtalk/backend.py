"""The ``uavtalk`` flight-controller backend: the FlightController protocol over UAVObjects.

This is the seed's Flight Controller Interface (4.1.2.1) on top of :class:`UAVTalkLink`, with the
parts of the Navigation Processor (4.1.2.2) and Arming Switch (4.1.2.4) that touch the autopilot:

* state comes from the objects the flight side sends periodically (GPSPosition, AttitudeActual,
  FlightStatus, VelocityActual, FlightBatteryState, SystemStats for the clock) and HomeLocation;
* ``goto`` converts the LLA target to NED relative to HomeLocation (exact WGS84 tangent plane of
  :mod:`dronefleet.geo.ned`, not the spherical Figure 4.13) and writes a ``Waypoint``;
* arming, take-off, landing, hold and reboot are ``FlightCommand`` writes (our stand-in for the
  seed's stick emulator); a refusal comes back as a NACK whose reason the flight side put in
  ``FlightCommandStatus``, raised here as :class:`FcError`;
* ``request_object`` is a fresh OBJ_REQ, answered in SI units (latitude in degrees, enums by name,
  False/True enums as booleans), the same shape as the in-process sim backend's.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import AsyncIterator
from typing import Any

from dronefleet.drone.fc.clock import AutopilotClock
from dronefleet.drone.fc.uavtalk.link import LinkError, UAVTalkLink
from dronefleet.geo.ned import lla_to_ned
from dronefleet.geo.types import LLA, NED
from dronefleet.protocols.uavtalk.objects import FieldType, ObjectDef
from dronefleet.protocols.uavtalk.registry import ObjectRegistry
from dronefleet.vehicle.base import (
    Attitude,
    BatteryState,
    FcError,
    FlightMode,
    GpsFix,
    GpsState,
    VehicleState,
    telemetry_sample,
)

#: Objects fetched on connect so every getter has a value from the start.
_INITIAL = (
    "HomeLocation",
    "FlightStatus",
    "SystemStats",
    "GPSPosition",
    "AttitudeActual",
    "VelocityActual",
    "FlightBatteryState",
)
#: Wall seconds without a FlightStatus before a wait gives up (it comes five times a second).
_STATUS_SILENCE_S = 5.0
#: GPSPosition.Status: anything better than Fix2D (Fix3D, Diff3D) is a 3-D fix.
_GPS_FIX = {"NoGPS": GpsFix.NO_GPS, "NoFix": GpsFix.NO_FIX, "Fix2D": GpsFix.FIX_2D}


class UAVTalkFlightController:
    """FlightController for a UAVTalk autopilot (a dRonin board, or our simulator)."""

    def __init__(self, link: UAVTalkLink, *, telemetry_rate_hz: float = 5.0) -> None:
        if telemetry_rate_hz <= 0:
            raise ValueError("telemetry rate must be positive")
        self.link = link
        self.telemetry_rate_hz = telemetry_rate_hz
        self._clock = AutopilotClock()
        self._sequence = itertools.count(1)
        self._closed = False
        self._hooked = False

    @property
    def clock(self) -> AutopilotClock:
        return self._clock

    @property
    def registry(self) -> ObjectRegistry:
        return self.link.registry

    async def connect(self) -> None:
        """Open the link (if not open) and fetch the objects the getters need."""
        self._closed = False
        if not self._hooked:
            self._hooked = True
            self.link.subscribe("SystemStats", self._on_system_stats)
            self.link.on_reconnect(self.rebuild_telemetry)
        await self.link.open()
        await self.rebuild_telemetry()

    async def close(self) -> None:
        self._closed = True
        await self.link.close()

    def _on_system_stats(self, _name: str, _instance: int, values: dict[str, Any]) -> None:
        self._clock.observe(values["FlightTime"])  # milliseconds since boot

    # -- commands ------------------------------------------------------------------------------
    async def _command(self, command: str, *, altitude_m: float = 0.0, force: bool = False) -> None:
        values = {
            "Command": command,
            "Altitude": altitude_m,
            "Force": force,
            "Sequence": next(self._sequence) & 0xFFFF,
        }
        await self.link.write("FlightCommand", values)

    async def arm(self) -> None:
        await self._command("Arm")
        while (status := self._wire("FlightStatus"))["Armed"] != "Armed":
            if status["Armed"] == "Disarmed":
                raise FcError(f"{self.link.url}: arming was interrupted")
            await self.link.wait_update("FlightStatus", _STATUS_SILENCE_S)

    async def disarm(self, *, force: bool = False) -> None:
        await self._command("Disarm", force=force)

    async def takeoff(self, altitude_m: float) -> None:
        await self._command("Takeoff", altitude_m=altitude_m)

    async def land(self) -> None:
        await self._command("Land")

    async def hold(self) -> None:
        await self._command("Hold")

    async def goto(self, target: LLA) -> None:
        home = self.home()
        if target.alt_m < home.alt_m:
            raise FcError(
                f"{self.link.url}: target altitude {target.alt_m:.1f} m AMSL is below home"
                f" ({home.alt_m:.1f} m AMSL)"
            )
        ned = lla_to_ned(target, home)
        waypoint = {
            "Position": {"North": ned.n, "East": ned.e, "Down": ned.d},
            "Velocity": 0.0,  # the autopilot's own cruise speed
            "Mode": "FlyEndpoint",
        }
        await self.link.write("Waypoint", waypoint, instance=0)

    async def reboot(self, *, force: bool = False) -> None:
        """Restart the autopilot; returns once FlightStatus says it is back."""
        await self._command("Reboot", force=force)
        while self._wire("FlightStatus")["Rebooting"] == "True":
            await self.link.wait_update("FlightStatus", _STATUS_SILENCE_S)

    async def rebuild_telemetry(self) -> None:
        """Re-request every object the getters use (after a reconnection, or on demand)."""
        for name in _INITIAL:
            await self.link.request(name)

    async def request_object(self, name: str) -> dict[str, Any]:
        if name not in self.registry:
            known = ", ".join(sorted(d.name for d in self.registry))
            raise FcError(f"unknown object {name!r}; known: {known}")
        return si_view(self.registry[name], await self.link.request(name))

    # -- latest state ---------------------------------------------------------------------------
    def _wire(self, name: str) -> dict[str, Any]:
        values = self.link.latest(name)
        if values is None:
            raise LinkError(f"{self.link.url}: no {name} received yet; connect() first")
        return values

    def _si(self, name: str) -> dict[str, Any]:
        return si_view(self.registry[name], self._wire(name))

    def position(self) -> LLA:
        gps = self._si("GPSPosition")
        return LLA(gps["Latitude"], gps["Longitude"], gps["Altitude"])

    def gps(self) -> GpsState:
        """GPSPosition's Status (NoGPS, NoFix, Fix2D, Fix3D, Diff3D) and Satellites; dRonin
        estimates no wind, so this backend has no ``wind()``."""
        values = self.link.latest("GPSPosition")
        if values is None:
            return GpsState(GpsFix.NO_GPS, 0)
        gps = si_view(self.registry["GPSPosition"], values)
        fix = _GPS_FIX.get(str(gps["Status"]), GpsFix.FIX_3D)
        return GpsState(fix, int(gps["Satellites"]), gps.get("HDOP"))

    def home(self) -> LLA:
        home = self._si("HomeLocation")
        return LLA(home["Latitude"], home["Longitude"], home["Altitude"])

    def velocity(self) -> NED:
        v = self._wire("VelocityActual")
        return NED(v["North"], v["East"], v["Down"])

    def battery(self) -> BatteryState:
        b = self._wire("FlightBatteryState")
        return BatteryState(
            remaining_pct=b["RemainingPct"],
            voltage_v=b["Voltage"],
            current_a=b["Current"],
            consumed_mah=b["ConsumedEnergy"],
            capacity_mah=b["Capacity"],
            cell_count=b["NbCells"],
        )

    def attitude(self) -> Attitude:
        a = self._wire("AttitudeActual")
        return Attitude(a["Roll"], a["Pitch"], a["Yaw"])

    def state(self) -> VehicleState:
        s = self._wire("FlightStatus")
        mode = s["FlightMode"]
        return VehicleState(
            armed=s["Armed"] == "Armed",
            arming=s["Armed"] == "Arming",
            in_air=s["InAir"] == "True",
            mode=FlightMode(mode) if isinstance(mode, str) else FlightMode.STABILIZE,
            landing=s["Landing"] == "True",
        )

    async def telemetry(self, rate_hz: float | None = None) -> AsyncIterator[dict[str, float]]:
        """Flat samples every ``1/rate_hz`` vehicle seconds until :meth:`close`."""
        period_s = 1.0 / (rate_hz or self.telemetry_rate_hz)
        while not self._closed:
            yield self.telemetry_sample()
            await self._clock.sleep(period_s)

    def telemetry_sample(self) -> dict[str, float]:
        return telemetry_sample(self)


def si_view(definition: ObjectDef, values: dict[str, Any]) -> dict[str, Any]:
    """Wire values in SI units, False/True enums as booleans, ``uint8`` text as ``str``."""
    out = definition.to_si(values)
    for f in definition.fields:
        value = out[f.name]
        if f.type is FieldType.ENUM and f.options == ("False", "True"):
            out[f.name] = value == "True"
        elif f.type is FieldType.UINT8 and f.elements > 8 and isinstance(value, list):
            out[f.name] = bytes(value).rstrip(b"\0").decode("ascii", "replace")
        elif isinstance(value, float) and not math.isfinite(value):
            out[f.name] = None  # JSON has no NaN
    return out
