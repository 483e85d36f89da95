"""JSON on the wire (orjson): encode models and dicts, decode bytes with a clear error."""

from __future__ import annotations

from typing import Any

import orjson
from pydantic import BaseModel

from dronefleet.errors import InvalidInput


class MessageError(InvalidInput, ValueError):
    """A message that cannot be decoded or does not fit its schema. It is logged and dropped."""


def encode(message: BaseModel | dict[str, Any] | list[Any]) -> bytes:
    if isinstance(message, BaseModel):
        return orjson.dumps(message.model_dump(mode="json", exclude_none=True))
    return orjson.dumps(message)


def decode(payload: bytes | bytearray | str) -> Any:
    try:
        return orjson.loads(payload)
    except orjson.JSONDecodeError as exc:
        raise MessageError(f"payload is not valid JSON: {exc}") from exc


def decode_object(payload: bytes | bytearray | str) -> dict[str, Any]:
    value = decode(payload)
    if not isinstance(value, dict):
        raise MessageError(f"payload must be a JSON object, got {type(value).__name__}")
    return value
