"""The payload of a MAVLink vehicle for the Gear Manager (seed Figure 3.5): a gas sensor whose
readings the autopilot (or a companion script on it) publishes as NAMED_VALUE_FLOAT, and the
autopilot's camera trigger (MAV_CMD_IMAGE_START_CAPTURE → CAMERA_IMAGE_CAPTURED).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from dronefleet.drone.fc.base import FcError
from dronefleet.drone.fc.mavlink.codec import dialect as mav
from dronefleet.drone.fc.mavlink.link import LinkLost
from dronefleet.drone.payload import Reading

if TYPE_CHECKING:
    from dronefleet.drone.fc.mavlink.controller import MavlinkFlightController


class NamedValueSensor:
    """A sensor read from NAMED_VALUE_FLOAT ``name`` (e.g. "CO2" in ppm)."""

    def __init__(self, fc: MavlinkFlightController, name: str = "CO2", unit: str = "ppm") -> None:
        self.name = name
        self.unit = unit
        self._fc = fc

    def read(self) -> Reading:
        latest = self._fc.named_values.get(self.name)
        if latest is None:
            raise FcError(f"no {self.name} reading from the autopilot yet")
        value, when = latest
        here = self._fc.position()
        return Reading(
            sensor=self.name,
            value=value,
            unit=self.unit,
            vehicle_time_s=when,
            extra={"lat": here.lat, "lon": here.lon, "alt_m": here.alt_m},
        )


class AutopilotCamera:
    """Triggers the autopilot's camera; the picture's own record (CAMERA_IMAGE_CAPTURED) lands in
    ``fc.captures`` when the autopilot reports it."""

    def __init__(self, fc: MavlinkFlightController, name: str = "camera") -> None:
        self.name = name
        self._fc = fc
        self._count = 0

    def capture(self) -> dict[str, Any]:
        fc = self._fc
        self._count += 1
        command = mav.MAVLink_command_long_message(
            fc.link.target_system or 0, fc.link.target_component,
            mav.MAV_CMD_IMAGE_START_CAPTURE, 0, 0, 0, 1, self._count, math.nan, math.nan, math.nan,
        )  # fmt: skip
        try:
            fc.link.send(command)  # the Camera protocol is synchronous: the ACK is not awaited
        except LinkLost as exc:
            raise FcError(f"camera: {exc}") from exc
        here = fc.position()
        return {
            "index": self._count,
            "lat": here.lat,
            "lon": here.lon,
            "alt_m": here.alt_m,
            "relative_alt_m": here.alt_m - fc.home().alt_m,
            "vehicle_time_s": fc.clock.now(),
        }
