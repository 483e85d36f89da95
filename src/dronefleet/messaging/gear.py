"""Gear Manager queries on ``<id>/gear/in`` and answers on ``<id>/gear/out`` (Listings 4.1, 4.2).

``photo`` (issue 14) fetches a picture the camera took, by its file name, in chunks of at most
:data:`PHOTO_CHUNK_BYTES`: a camera's JPEG (megabytes) would not fit in one broker message (the
clients drop any over 2 MB), and each chunk is a request of its own, retried alone.
"""

from __future__ import annotations

from enum import StrEnum
from typing import Any

from pydantic import Base64Bytes, Field

from dronefleet.messaging.commands import RequestId
from dronefleet.messaging.common import DroneId, Message, wall_time


class GearQuery(StrEnum):
    SPECS = "specs"  # drone specifications (Listing 4.1)
    SENSORS = "sensors"  # connected sensors (Listing 4.2)
    READING = "reading"  # a sensor reading
    CAPTURE = "capture"  # take a picture
    PHOTO = "photo"  # a chunk of a picture taken (by its file name, from an offset)


#: Bytes of a picture per answer: ~350 kB of base64 JSON, well inside a broker message.
PHOTO_CHUNK_BYTES = 256 * 1024
#: A picture's file name as the drone reports it (no folders: the drone serves only its own).
PHOTO_NAME = r"^[A-Za-z0-9][A-Za-z0-9._-]{0,127}$"


class GearRequest(Message):
    request_id: RequestId | None = None
    query: GearQuery
    sensor: str | None = Field(default=None, max_length=64)
    photo: str | None = Field(default=None, pattern=PHOTO_NAME)
    offset: int = Field(default=0, ge=0, le=2**40)


class PhotoChunk(Message):
    """Part of a picture: ``data`` holds its bytes from ``offset`` (base64 on the wire)."""

    file: str = Field(pattern=PHOTO_NAME)
    size_bytes: int = Field(ge=0)
    offset: int = Field(ge=0)
    data: Base64Bytes = Field(max_length=PHOTO_CHUNK_BYTES * 2)


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
    photo: PhotoChunk | None = None
    timestamp: float = Field(default_factory=wall_time)
