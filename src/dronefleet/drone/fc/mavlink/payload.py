"""The payload of a MAVLink vehicle for the Gear Manager (seed Figure 3.5): a gas sensor whose
readings the autopilot (or a companion script on it) publishes as NAMED_VALUE_FLOAT, and the
autopilot's camera trigger (MAV_CMD_IMAGE_START_CAPTURE → CAMERA_IMAGE_CAPTURED).
"""

from __future__ import annotations

import asyncio
from typing import TYPE_CHECKING, Any

from dronefleet.protocols.mavlink.codec import Message, text_field
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.vehicle.base import FcError
from dronefleet.vehicle.payload import Reading

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
    """Triggers the autopilot's camera and reports a picture only once the autopilot confirms it:
    the COMMAND_ACK must be ACCEPTED (SITL without a camera, CAM1_TYPE 0, answers FAILED), then
    the autopilot's record of the picture (CAMERA_IMAGE_CAPTURED, or ArduPilot's CAMERA_FEEDBACK)
    must arrive. Before, the ACK was not awaited and 28 photos that were never taken were
    reported as taken (issue 17)."""

    #: Wall seconds to wait for the picture's record once the trigger is accepted.
    FEEDBACK_TIMEOUT_S = 5.0

    def __init__(self, fc: MavlinkFlightController, name: str = "camera") -> None:
        self.name = name
        self._fc = fc
        self._count = 0

    async def capture(self) -> dict[str, Any]:
        fc = self._fc
        index = self._count + 1
        kinds = ("CAMERA_IMAGE_CAPTURED", "CAMERA_FEEDBACK")
        seen = {kind: fc.link.latest.get(kind) for kind in kinds}  # records before this trigger
        feedback = asyncio.ensure_future(
            fc.link.wait_for(
                ("CAMERA_IMAGE_CAPTURED", "CAMERA_FEEDBACK"), None, self.FEEDBACK_TIMEOUT_S
            )
        )
        try:
            await fc.commands.long(mav.MAV_CMD_IMAGE_START_CAPTURE, 0, 0, 1, index)
        except FcError as exc:
            feedback.cancel()
            raise FcError(f"camera: no picture taken: {exc}") from exc
        record = await feedback
        if record is None:  # a record that came before the waiter was listening still counts
            record = next(
                (m for k in kinds if (m := fc.link.latest.get(k)) is not None and m is not seen[k]),
                None,
            )
        if record is None:
            raise FcError(
                "camera: the autopilot accepted the trigger but reported no picture (no "
                f"CAMERA_IMAGE_CAPTURED or CAMERA_FEEDBACK within {self.FEEDBACK_TIMEOUT_S:g} s)"
            )
        self._count = index
        here = fc.position()
        return {
            "index": index,
            "lat": here.lat,
            "lon": here.lon,
            "alt_m": here.alt_m,
            "relative_alt_m": here.alt_m - fc.home().alt_m,
            "vehicle_time_s": fc.clock.now(),
            "confirmed_by": record.get_type(),
        }


def capture_record(msg: Message) -> dict[str, Any]:
    """A CAMERA_IMAGE_CAPTURED message as the controller keeps it (``captures``)."""
    return {
        "index": msg.image_index,
        "lat": msg.lat / 1e7,
        "lon": msg.lon / 1e7,
        "alt_m": msg.alt / 1000.0,
        "relative_alt_m": msg.relative_alt / 1000.0,
        "vehicle_time_s": msg.time_boot_ms / 1000.0,
        "file": text_field(msg.file_url) or None,
        "ok": msg.capture_result == 1,
    }
