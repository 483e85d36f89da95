"""Gear Manager queries on ``<id>/gear/in`` and answers on ``<id>/gear/out`` (Listings 4.1, 4.2)."""

from __future__ import annotations

from enum import StrEnum
from typing import Any

from pydantic import Field

from dronefleet.messaging.commands import RequestId
from dronefleet.messaging.common import DroneId, Message, wall_time


class GearQuery(StrEnum):
    SPECS = "specs"  # drone specifications (Listing 4.1)
    SENSORS = "sensors"  # connected sensors (Listing 4.2)
    READING = "reading"  # a sensor reading
    CAPTURE = "capture"  # take a picture


class GearRequest(Message):
    request_id: RequestId | None = None
    query: GearQuery
    sensor: str | None = Field(default=None, max_length=64)


class GearReply(Message):
    request_id: str | None
    drone_id: DroneId
    query: str | None
    ok: bool
    error: str | None = None
    specs: dict[str, Any] | None = None
    sensors: dict[str, Any] | None = None
    reading: dict[str, Any] | None = None
    capture: dict[str, Any] | None = None
    timestamp: float = Field(default_factory=wall_time)
