"""Pieces every message shares: positions, request ids, validation errors as readable reasons."""

from __future__ import annotations

import secrets
from enum import StrEnum
from typing import Annotated, Any

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, TypeAdapter, ValidationError

from dronefleet.clock import timestamp_s
from dronefleet.messaging.codec import MessageError
from dronefleet.messaging.topics import TopicError, check_drone_id


def new_request_id() -> str:
    """16 cryptographically strong random bytes as hex, as the seed's Drone Manager does."""
    return secrets.token_hex(16)


def wall_time() -> float:
    """Unix time in seconds on the running loop's clock (virtual in a simulation); every message
    carries it beside the vehicle time."""
    return timestamp_s()


def _a_drone_id(value: str) -> str:
    try:
        return check_drone_id(value)
    except TopicError as exc:
        raise ValueError(str(exc)) from exc


#: A drone id as topics allow it (messaging/topics.py): what a drone may call itself in any
#: message. Ids reach web pages and logs, so nothing else is accepted (issue 12).
DroneId = Annotated[str, AfterValidator(_a_drone_id)]


class Message(BaseModel):
    """Base of every wire message: unknown fields are refused so typos surface as errors."""

    model_config = ConfigDict(extra="forbid", frozen=False, populate_by_name=True)


class Position(Message):
    """A geographic position: WGS84 degrees, altitude above mean sea level in metres."""

    lat: float = Field(ge=-90, le=90)
    lon: float = Field(ge=-180, le=180)
    alt_m: float = Field(ge=-500, le=10_000)
    relative_alt_m: float | None = Field(default=None, description="height above home")


def reason(exc: ValidationError) -> str:
    """A one-line reason from a pydantic error, e.g. ``lat: Input should be ... to 90``."""
    parts = []
    for err in exc.errors(include_url=False):
        # The first location element of a tagged union is the tag itself: drop it.
        loc = [str(p) for p in err["loc"]]
        if len(loc) > 1 and err["loc"][0] in {m.value for m in _tags()}:
            loc = loc[1:]
        where = ".".join(loc)
        parts.append(f"{where}: {err['msg']}" if where else err["msg"])
    return "; ".join(parts)


def _tags() -> type[StrEnum]:
    from dronefleet.messaging.commands import Command

    return Command


def validate(adapter: TypeAdapter[Any] | type[BaseModel], data: Any) -> Any:
    """Validate ``data`` against a model or adapter, raising :class:`MessageError` with a reason."""
    try:
        if isinstance(adapter, TypeAdapter):
            return adapter.validate_python(data)
        return adapter.model_validate(data)
    except ValidationError as exc:
        raise MessageError(reason(exc)) from exc
