"""The ``mavlink`` flight-controller backend (Flight Controller Interface, seed 3.3.2.2 / 4.1.2.1):
ArduPilot Copter and PX4 over pymavlink, found by ``dronefleet drone --fc mavlink --fc-url URL``.

Modules: :mod:`.codec` (framing), :mod:`.link` (asyncio link, heartbeat watchdog), :mod:`.clock`
(the autopilot's time), :mod:`.commands` (COMMAND_LONG/ACK with retries), :mod:`.modes` (ArduPilot
and PX4 mode encodings), :mod:`.items` and :mod:`.mission` (missions on board), :mod:`.objects`
(objrequest), :mod:`.payload` (gas sensor and camera), :mod:`.session` and :mod:`.flight_params`
(what is asked for and read on connect), :mod:`.state`, :mod:`.mode_watch` and :mod:`.guided` (the
controller's state getters, mode changes and flying to a point), :mod:`.controller` (the
FlightController).
"""

from __future__ import annotations

import logging
from typing import Any

from dronefleet.drone.fc.mavlink.controller import MavlinkFlightController
from dronefleet.drone.fc.mavlink.mission import MissionProgress
from dronefleet.drone.fc.mavlink.payload import AutopilotCamera, NamedValueSensor
from dronefleet.protocols.mavlink.items import MissionItem
from dronefleet.vehicle.payload import Camera, Sensor

__all__ = [
    "AutopilotCamera",
    "MavlinkFlightController",
    "MissionItem",
    "MissionProgress",
    "NamedValueSensor",
    "open_flight_controller",
    "payload",
]


log = logging.getLogger(__name__)


async def open_flight_controller(url: str, **options: Any) -> MavlinkFlightController:
    """A connected controller for the autopilot at ``url`` (home known); ``options`` go to
    :class:`MavlinkFlightController` (e.g. ``telemetry_rate_hz``, ``target_system``)."""
    fc = MavlinkFlightController(url, **options)
    await fc.connect()
    return fc


def payload(fc: MavlinkFlightController) -> tuple[dict[str, Sensor], Camera | None]:
    """The Gear Manager's view of the vehicle: a CO2 sensor and the autopilot's camera — none
    when the autopilot says it has none (ArduPilot's CAM1_TYPE 0), so the gear check reports
    "no camera" at start and a photo step fails with that reason."""
    camera: Camera | None = AutopilotCamera(fc)
    if fc.params.get("camera_type") == 0:
        log.warning("autopilot %s has no camera (CAM1_TYPE 0): photos will be refused", fc.url)
        camera = None
    return {"CO2": NamedValueSensor(fc, "CO2", "ppm")}, camera
