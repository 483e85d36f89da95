"""Choosing a flight-controller backend by name (``--fc sim|mavlink|uavtalk``).

Each non-sim backend module exposes ``async def open_flight_controller(url: str, **options)``
returning a connected :class:`~dronefleet.vehicle.base.FlightController`, plus optionally
``payload(fc) -> (sensors, camera)`` for the Gear Manager. The sim backend is built by
:class:`~dronefleet.simfleet.SimFleet` instead, because its vehicles live in-process.
"""

from __future__ import annotations

import importlib
from typing import Any

from dronefleet.errors import Unavailable
from dronefleet.vehicle.base import FlightController

BACKENDS = {
    "mavlink": "dronefleet.drone.fc.mavlink",
    "uavtalk": "dronefleet.drone.fc.uavtalk",
}


class BackendUnavailable(Unavailable, RuntimeError):
    pass


def backend_module(kind: str) -> Any:
    if kind not in BACKENDS:
        raise BackendUnavailable(
            f"unknown flight-controller backend {kind!r}; known: sim, {', '.join(BACKENDS)}"
        )
    try:
        return importlib.import_module(BACKENDS[kind])
    except ModuleNotFoundError as exc:
        raise BackendUnavailable(f"backend {kind!r} is not available: {exc}") from exc


async def open_flight_controller(
    kind: str, url: str, **options: Any
) -> tuple[FlightController, dict, Any]:
    """Connect to an autopilot; returns the controller, its sensors and its camera (or None)."""
    module = backend_module(kind)
    fc = await module.open_flight_controller(url, **options)
    sensors, camera = ({}, None)
    if hasattr(module, "payload"):
        sensors, camera = module.payload(fc)
    return fc, sensors, camera
