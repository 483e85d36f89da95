"""UAVTalk framing: the bytes between the Flight Controller Interface and a dRonin board.

Seed 4.1.2.1: the Drone Controller talked to the Flight Controller in UAVTalk, the binary protocol
of OpenPilot, LibrePilot, TauLabs and dRonin. One frame carries one UAVObject instance (or a
request, an acknowledgement, a refusal)::

    sync 0x3C | type | length (u16 LE) | object id (u32 LE) | [instance id (u16 LE)]
              | [timestamp (u16 LE)] | data | CRC-8

* ``type`` is ``0x20 | message``; bits 3..6 must read ``0x20`` (the protocol version) and bit 7
  marks the timestamped variants, which carry 16 bits of sender milliseconds after the instance id.
* ``length`` counts the header, instance id, timestamp and data, not the CRC.
* The instance id is present only for multi-instance objects (never in a NACK), so splitting a
  frame's body needs to know the object: callers pass ``multi_instance(object_id)``.
* The CRC is CRC-8 with polynomial 0x07 (x^8 + x^2 + x + 1), initial value 0, no reflection,
  over every byte from the sync byte to the end of the data.

:class:`FrameParser` is the streaming side: it takes bytes as they arrive, returns whole frames,
and on anything wrong (bad type, impossible length, bad CRC) drops the sync byte it had taken and
resynchronises on the next one, so line noise costs frames, never the link. Like dRonin's own
byte-wise parser it trusts a plausible length until that many bytes have arrived, so a false
candidate can hold the frames behind it for up to one maximum frame (269 bytes) of traffic.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import IntEnum

from dronefleet.errors import InvalidInput

SYNC = 0x3C
VERSION = 0x20
TYPE_MASK = 0x78
TIMESTAMPED = 0x80
#: sync, type, length, object id.
HEADER_LENGTH = 8
#: The largest object data we accept (dRonin's largest objects are a few hundred bytes).
MAX_DATA_LENGTH = 256
MAX_FRAME_LENGTH = HEADER_LENGTH + 4 + MAX_DATA_LENGTH  # without the CRC byte

_HEADER = struct.Struct("<BBHI")
_U16 = struct.Struct("<H")


class MessageType(IntEnum):
    OBJ = VERSION | 0x00  # an object update, no reply expected
    OBJ_REQ = VERSION | 0x01  # "send me this object"; answered by OBJ or NACK
    OBJ_ACK = VERSION | 0x02  # an object update that must be acknowledged (ACK or NACK)
    ACK = VERSION | 0x03
    NACK = VERSION | 0x04  # unknown object, or (in dronefleet) a refused write
    OBJ_TS = TIMESTAMPED | OBJ
    OBJ_ACK_TS = TIMESTAMPED | OBJ_ACK

    @property
    def timestamped(self) -> bool:
        return bool(self & TIMESTAMPED)

    @property
    def carries_data(self) -> bool:
        return self in _WITH_DATA


_WITH_DATA = frozenset(
    {MessageType.OBJ, MessageType.OBJ_ACK, MessageType.OBJ_TS, MessageType.OBJ_ACK_TS}
)
_TYPES = {t.value: t for t in MessageType}


class FrameError(InvalidInput, ValueError):
    """Bytes that are not a valid UAVTalk frame; the message says what was wrong."""


def _crc8_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = ((crc << 1) ^ 0x07) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
        table.append(crc)
    return tuple(table)


_CRC8 = _crc8_table()


def crc8(data: bytes | bytearray | memoryview, crc: int = 0) -> int:
    """CRC-8, polynomial 0x07 (``crc8(b"123456789") == 0xF4``)."""
    table = _CRC8
    for byte in data:
        crc = table[crc ^ byte]
    return crc


@dataclass(frozen=True, slots=True)
class Frame:
    """One UAVTalk message. ``data`` is the packed object (empty for OBJ_REQ, ACK and NACK)."""

    type: MessageType
    object_id: int
    instance_id: int = 0
    data: bytes = b""
    timestamp_ms: int | None = None  # timestamped variants only (16 bits, wraps)


def encode_frame(frame: Frame, *, multi_instance: bool = False) -> bytes:
    """The bytes of ``frame``, CRC included. ``multi_instance`` says whether the object carries
    an instance id (ignored for NACK, which never does)."""
    if not 0 <= frame.object_id <= 0xFFFFFFFF:
        raise FrameError(f"object id {frame.object_id} does not fit in 32 bits")
    if len(frame.data) > MAX_DATA_LENGTH:
        raise FrameError(f"{len(frame.data)} bytes of data; at most {MAX_DATA_LENGTH} fit")
    if frame.data and not frame.type.carries_data:
        raise FrameError(f"{frame.type.name} frames carry no data")
    extra = bytearray()
    if multi_instance and frame.type is not MessageType.NACK:
        extra += _U16.pack(frame.instance_id & 0xFFFF)
    if frame.type.timestamped:
        extra += _U16.pack((frame.timestamp_ms or 0) & 0xFFFF)
    length = HEADER_LENGTH + len(extra) + len(frame.data)
    out = bytearray(_HEADER.pack(SYNC, frame.type, length, frame.object_id))
    out += extra
    out += frame.data
    out.append(crc8(out))
    return bytes(out)


def _split_body(
    kind: MessageType, object_id: int, body: bytes, multi_instance: Callable[[int], bool]
) -> Frame:
    instance_id = 0
    timestamp = None
    offset = 0
    if kind is not MessageType.NACK and multi_instance(object_id):
        if len(body) < 2:
            raise FrameError(
                f"{kind.name} for multi-instance object {object_id:#010x}: no instance"
            )
        (instance_id,) = _U16.unpack_from(body, 0)
        offset = 2
    if kind.timestamped:
        if len(body) < offset + 2:
            raise FrameError(f"{kind.name} without its timestamp")
        (timestamp,) = _U16.unpack_from(body, offset)
        offset += 2
    data = bytes(body[offset:])
    if data and not kind.carries_data:
        raise FrameError(f"{kind.name} frame with {len(data)} unexpected data bytes")
    return Frame(kind, object_id, instance_id, data, timestamp)


def _check_header(kind_byte: int, length: int) -> MessageType:
    if kind_byte & TYPE_MASK != VERSION or kind_byte not in _TYPES:
        raise FrameError(f"type byte {kind_byte:#04x} is not a UAVTalk v2 message type")
    if not HEADER_LENGTH <= length <= MAX_FRAME_LENGTH:
        raise FrameError(f"length {length} outside {HEADER_LENGTH}..{MAX_FRAME_LENGTH}")
    return _TYPES[kind_byte]


def decode_frame(
    raw: bytes | bytearray, *, multi_instance: Callable[[int], bool] = lambda _id: False
) -> Frame:
    """Decode exactly one frame; raises :class:`FrameError` on any defect."""
    if len(raw) < HEADER_LENGTH + 1:
        raise FrameError(f"{len(raw)} bytes is shorter than the smallest frame")
    sync, kind_byte, length, object_id = _HEADER.unpack_from(raw, 0)
    if sync != SYNC:
        raise FrameError(f"first byte {sync:#04x} is not the sync byte 0x3C")
    kind = _check_header(kind_byte, length)
    if len(raw) != length + 1:
        raise FrameError(f"frame says {length + 1} bytes with CRC, got {len(raw)}")
    if crc8(memoryview(raw)[:length]) != raw[length]:
        raise FrameError("CRC mismatch")
    return _split_body(kind, object_id, bytes(raw[HEADER_LENGTH:length]), multi_instance)


@dataclass
class ParserStats:
    frames: int = 0
    crc_errors: int = 0
    malformed: int = 0
    skipped_bytes: int = 0


@dataclass
class FrameParser:
    """Streaming decoder: ``for frame in parser.feed(chunk): ...``; never raises on input."""

    multi_instance: Callable[[int], bool] = lambda _id: False
    stats: ParserStats = field(default_factory=ParserStats)
    _buf: bytearray = field(default_factory=bytearray)

    def feed(self, chunk: bytes | bytearray) -> list[Frame]:
        buf = self._buf
        buf += chunk
        frames: list[Frame] = []
        while True:
            start = buf.find(SYNC)
            if start < 0:
                self.stats.skipped_bytes += len(buf)
                buf.clear()
                return frames
            if start:
                self.stats.skipped_bytes += start
                del buf[:start]
            if len(buf) < 4:
                return frames
            kind_byte, length = buf[1], buf[2] | buf[3] << 8
            try:
                kind = _check_header(kind_byte, length)
            except FrameError:
                self._resync()
                continue
            if len(buf) < length + 1:
                return frames  # wait for the rest
            if crc8(memoryview(buf)[:length]) != buf[length]:
                self.stats.crc_errors += 1
                self._resync()
                continue
            (object_id,) = struct.unpack_from("<I", buf, 4)
            body = bytes(buf[HEADER_LENGTH:length])
            del buf[: length + 1]
            try:
                frames.append(_split_body(kind, object_id, body, self.multi_instance))
                self.stats.frames += 1
            except FrameError:
                self.stats.malformed += 1

    def _resync(self) -> None:
        """Drop the sync byte we started on; the next search finds the following one."""
        self.stats.skipped_bytes += 1
        del self._buf[:1]

    @property
    def pending(self) -> int:
        """Bytes held while waiting for the rest of a frame."""
        return len(self._buf)
