"""What the Gear Manager reads and triggers: sensors and a camera (seed Figure 3.5).

Real drones implement these over I2C/UART/Wi-Fi; the simulator implements them over its gas field
and camera model.
"""

from __future__ import annotations

from collections.abc import Awaitable
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable


@dataclass(frozen=True)
class Reading:
    sensor: str  # e.g. "CO2"
    value: float
    unit: str  # e.g. "ppm"
    vehicle_time_s: float
    extra: dict[str, Any] = field(default_factory=dict)


@runtime_checkable
class Sensor(Protocol):
    name: str  # key in the sensor list, e.g. "CO2"
    unit: str

    def read(self) -> Reading: ...


@runtime_checkable
class Camera(Protocol):
    name: str

    def capture(self) -> dict[str, Any] | Awaitable[dict[str, Any]]:
        """Take a picture; returns (or, for a camera that confirms later, resolves to) at least
        ``lat``, ``lon``, ``alt_m``, ``vehicle_time_s`` and ``index``, and ``file`` when an image
        file was written. Raises when no picture was taken."""
        ...
