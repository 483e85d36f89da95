"""MAVLink 2 framing for the Flight Controller Interface (seed 3.3.2.2, 4.1.2.1).

pymavlink's generated ``ardupilotmega`` dialect (a superset of ``common``) does the byte work; this
module fixes how we use it on both ends of the link — the drone's MAVLink backend and the
simulator's vehicle endpoint: one :class:`Encoder` per sender (sequence numbers, our system and
component ids) and one :class:`FrameDecoder` per receiver that never raises on bad input. Corrupt,
truncated or random bytes are counted and dropped; a component never dies on input
(docs/DESIGN.md §3).
"""

from __future__ import annotations

import hashlib
import logging
import re
import time
from typing import Any, TypeAlias

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

log = logging.getLogger(__name__)

#: The dialect module: message classes (``mavlink2.MAVLink_heartbeat_message``) and enums.
dialect = mavlink2

Message: TypeAlias = mavlink2.MAVLink_message  # pymavlink ships no type information


# -- MAVLink 2 message signing (https://mavlink.io/en/guide/message_signing.html) ------------------
#: Signing timestamps count 10 µs units from 2015-01-01 00:00 UTC.
_SIGNING_EPOCH_S = 1420070400
#: What a signing end still takes unsigned: RADIO_STATUS, which a telemetry radio injects into the
#: link and cannot sign (the signing guide's example of an accept-unsigned callback).
UNSIGNED_ALLOWED = frozenset({mavlink2.MAVLINK_MSG_ID_RADIO_STATUS})
_HEX_KEY = re.compile(r"[0-9a-fA-F]{64}")


def signing_key(secret: str) -> bytes:
    """The 32-byte secret key for ``secret``: 64 hex digits are the key itself; anything else is a
    passphrase, hashed with SHA-256 as MAVProxy's ``signing setup`` and QGroundControl do, so the
    same passphrase signs for all of them."""
    secret = secret.strip()
    if not secret:
        raise ValueError("an empty MAVLink signing key")
    if _HEX_KEY.fullmatch(secret):
        return bytes.fromhex(secret)
    return hashlib.sha256(secret.encode()).digest()


def enable_signing(mav: Any, key: bytes, link_id: int = 0) -> None:
    """Sign what ``mav`` packs and accept only correctly signed, fresh frames (but
    :data:`UNSIGNED_ALLOWED`); pymavlink checks signatures and replayed timestamps."""
    if len(key) != 32:
        raise ValueError("a MAVLink signing key is 32 bytes")
    signing = mav.signing
    signing.secret_key = key
    signing.sign_outgoing = True
    signing.link_id = link_id
    signing.timestamp = max(signing.timestamp, int((time.time() - _SIGNING_EPOCH_S) * 100_000))
    signing.allow_unsigned_callback = lambda _mav, msg_id: msg_id in UNSIGNED_ALLOWED


def _is_signature_refusal(message: Message) -> bool:
    return "signature" in str(getattr(message, "reason", "")).lower()


class Encoder:
    """Packs messages as one MAVLink 2 system/component, counting the sequence number; signs
    them when given a key."""

    def __init__(self, system_id: int, component_id: int, *, signing: bytes | None = None) -> None:
        self._mav = mavlink2.MAVLink(None, srcSystem=system_id, srcComponent=component_id)
        if signing is not None:
            enable_signing(self._mav, signing)

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
    """Bytes in, messages out; bad frames are counted in :attr:`errors`, never raised. With a
    signing key, frames not signed with it (or replayed) are dropped and counted in
    :attr:`unsigned`."""

    def __init__(self, *, signing: bytes | None = None) -> None:
        self._signing = mavlink2.MAVLinkSigning()
        if signing is not None:
            holder = mavlink2.MAVLink(None)
            enable_signing(holder, signing)
            self._signing = holder.signing
        self._mav = self._new_parser()
        self.errors = 0
        self.unknown = 0
        self.unsigned = 0
        self.messages = 0

    def _new_parser(self) -> Any:
        mav = mavlink2.MAVLink(None)
        mav.robust_parsing = True  # bad frames come back as BAD_DATA instead of exceptions
        mav.signing = self._signing  # streams' last timestamps outlive a parser reset
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
                if _is_signature_refusal(message):
                    self.unsigned += 1
                else:
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
