"""MAVFTP (FILE_TRANSFER_PROTOCOL), refused at once: the simulated autopilot has no files.

MAVProxy and QGroundControl first try to fetch the parameters as a file (``@PARAM/param.pck``)
and fall back to PARAM_REQUEST_LIST only when that fails; a vehicle that stays silent costs them
a timeout of many seconds (issue 10, item 3). So every request is answered straight away as
ArduPilot's AP_Filesystem would answer for a missing file: a NAK with FileNotFound for opening or
listing, Fail for the rest, and an ACK for ending sessions (there are none to end).

The payload (MAVLink's FTP message format): seq u16, session u8, opcode u8, size u8, req_opcode
u8, burst_complete u8, padding u8, offset u32, data[239]; the answer's seq is the request's + 1.
"""

from __future__ import annotations

import struct

from dronefleet.protocols.mavlink.codec import Message
from dronefleet.protocols.mavlink.codec import dialect as mav

TERMINATE_SESSION, RESET_SESSIONS, LIST_DIRECTORY, OPEN_FILE_RO = 1, 2, 3, 4
CREATE_FILE, OPEN_FILE_WO = 6, 11
ACK, NAK = 128, 129
ERR_FAIL, ERR_FILE_NOT_FOUND = 1, 10

_HEADER = struct.Struct("<HBBBBBBI")
_PAYLOAD_LEN = 251
_NOT_FOUND = {LIST_DIRECTORY, OPEN_FILE_RO, CREATE_FILE, OPEN_FILE_WO}


def answer(request: Message) -> Message:
    """The FILE_TRANSFER_PROTOCOL reply to ``request``."""
    raw = bytes(request.payload)
    seq, session, opcode = _HEADER.unpack_from(raw.ljust(_HEADER.size, b"\0"))[:3]
    if opcode in (TERMINATE_SESSION, RESET_SESSIONS):
        reply, data = ACK, b""
    else:
        reply, data = NAK, bytes([ERR_FILE_NOT_FOUND if opcode in _NOT_FOUND else ERR_FAIL])
    header = _HEADER.pack((seq + 1) % 65536, session, reply, len(data), opcode, 0, 0, 0)
    payload = (header + data).ljust(_PAYLOAD_LEN, b"\0")
    return mav.MAVLink_file_transfer_protocol_message(
        0, request.get_srcSystem(), request.get_srcComponent(), list(payload)
    )


def reply_fields(msg: Message) -> tuple[int, int, int, int, int]:
    """(seq, opcode, size, req_opcode, first data byte) of an FTP message (for tests and tools)."""
    raw = bytes(msg.payload)
    seq, _, opcode, size, req_opcode = _HEADER.unpack_from(raw)[:5]
    return seq, opcode, size, req_opcode, raw[_HEADER.size]
