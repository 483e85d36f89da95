"""Reading a broker message as its shared model: every consumer decodes and validates, or drops.

A consumer never reads a raw dict: ``parse_message(Alarm, payload)`` gives a validated
:class:`~dronefleet.messaging.status.Alarm` or raises :class:`MessageError` with the reason (the
consumer counts it and drops the message). Fields a newer sender adds are ignored, not refused,
so a ground keeps working with drones one version ahead; fields it knows must be valid.
"""

from __future__ import annotations

import functools
from typing import Any, TypeVar, cast

from pydantic import BaseModel, ConfigDict

from dronefleet.messaging.codec import MessageError, decode_object
from dronefleet.messaging.common import validate

M = TypeVar("M", bound=BaseModel)


@functools.cache
def lenient(model: type[M]) -> type[M]:
    """``model`` that ignores unknown fields (the wire models refuse them, to catch typos)."""
    namespace: dict[str, Any] = {
        "model_config": ConfigDict(extra="ignore"),
        "__module__": model.__module__,
        "__doc__": f"{model.__name__}, ignoring fields it does not know.",
    }
    return cast(type[M], type(f"Lenient{model.__name__}", (model,), namespace))


def parse_message(model: type[M], payload: bytes | bytearray | str) -> M:
    """The message in ``payload`` as ``model``; :class:`MessageError` with the reason if not."""
    return cast(M, validate(lenient(model), decode_object(payload)))


def speaks_for_itself(topic_name: str, drone_id: str) -> None:
    """A drone's message names the drone whose topic it came on; :class:`MessageError` if not
    (a message on ``QUAD_2/alarms/out`` about ``QUAD_1`` is not believed)."""
    owner = topic_name.split("/", 1)[0]
    if owner != drone_id:
        raise MessageError(f"message about {drone_id!r} on {owner!r}'s topic")
