"""MAVLink 2 framing for the Flight Controller Interface (seed 3.3.2.2, 4.1.2.1).

pymavlink's generated ``ardupilotmega`` dialect (a superset of ``common``) does the byte work; this
module fixes how we use it on both ends of the link — the drone's MAVLink backend and the
simulator's vehicle endpoint: one :class:`Encoder` per sender (sequence numbers, our system and
component ids) and one :class:`FrameDecoder` per receiver that never raises on bad input. Corrupt,
truncated or random bytes are counted and dropped; a component never dies on input
(docs/DESIGN.md §3).
"""

from __future__ import annotations

import logging
from typing import Any, TypeAlias

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

log = logging.getLogger(__name__)

#: The dialect module: message classes (``mavlink2.MAVLink_heartbeat_message``) and enums.
dialect = mavlink2

Message: TypeAlias = mavlink2.MAVLink_message  # pymavlink ships no type information


class Encoder:
    """Packs messages as one MAVLink 2 system/component, counting the sequence number."""

    def __init__(self, system_id: int, component_id: int) -> None:
        self._mav = mavlink2.MAVLink(None, srcSystem=system_id, srcComponent=component_id)

    @property
    def system_id(self) -> int:
        return int(self._mav.srcSystem)

    @system_id.setter
    def system_id(self, value: int) -> None:
        self._mav.srcSystem = value

    def pack(self, message: Message) -> bytes:
        data: bytes = message.pack(self._mav)
        self._mav.seq = (self._mav.seq + 1) % 256
        return data


class FrameDecoder:
    """Bytes in, messages out; bad frames are counted in :attr:`errors`, never raised."""

    def __init__(self) -> None:
        self._mav = self._new_parser()
        self.errors = 0
        self.unknown = 0
        self.messages = 0

    @staticmethod
    def _new_parser() -> Any:
        mav = mavlink2.MAVLink(None)
        mav.robust_parsing = True  # bad frames come back as BAD_DATA instead of exceptions
        return mav

    def reset(self) -> None:
        """Forget any partial frame (call at a datagram boundary: frames never span two)."""
        self._mav = self._new_parser()

    def feed(self, data: bytes) -> list[Message]:
        """Parse ``data`` (a stream chunk); returns the good messages it completed."""
        out: list[Message] = []
        try:
            got = self._mav.parse_buffer(data) or []
        except Exception as exc:  # pymavlink raises a zoo of types on hostile input
            log.debug("MAVLink parser gave up on %d bytes: %s", len(data), exc)
            self.errors += 1
            self.reset()
            return out
        for message in got:
            if message.get_type() == "BAD_DATA":
                self.errors += 1
            elif isinstance(message, mavlink2.MAVLink_unknown):
                # An id outside our dialect has no CRC seed to check it against: a corrupted id
                # looks exactly like this, so such frames are dropped, never trusted.
                self.unknown += 1
            else:
                out.append(message)
        self.messages += len(out)
        return out

    def feed_datagram(self, data: bytes) -> list[Message]:
        """Parse one UDP datagram on its own: a bad one cannot swallow the next."""
        self.reset()
        return self.feed(data)


def to_dict(message: Message) -> dict[str, Any]:
    """A message's fields as a plain dict (what ``objrequest`` answers with)."""
    fields = message.to_dict()
    fields.pop("mavpackettype", None)
    return {k: (list(v) if isinstance(v, (list, tuple)) else v) for k, v in fields.items()}


def text_field(value: str | bytes) -> str:
    """A ``char[]`` field as text (pymavlink gives str, older builds bytes)."""
    if isinstance(value, bytes):
        value = value.decode("utf-8", errors="replace")
    return value.rstrip("\x00")


def message_id(name: str) -> int:
    """The numeric id of a message type named like ``GLOBAL_POSITION_INT``."""
    value = getattr(mavlink2, f"MAVLINK_MSG_ID_{name.upper()}", None)
    if value is None:
        raise KeyError(f"unknown MAVLink message {name!r}")
    return int(value)


def message_name(msg_id: int) -> str:
    cls = mavlink2.mavlink_map.get(msg_id)
    return cls.msgname if cls is not None else f"MSG_{msg_id}"


def command_name(command: int) -> str:
    entry = mavlink2.enums["MAV_CMD"].get(command)
    return entry.name if entry is not None else f"MAV_CMD {command}"


def result_name(result: int) -> str:
    entry = mavlink2.enums["MAV_RESULT"].get(result)
    return entry.name.removeprefix("MAV_RESULT_") if entry is not None else str(result)
