"""MAVLink FTP (FILE_TRANSFER_PROTOCOL) refused at once: the simulator serves no files.

MAVProxy and QGroundControl first ask for the parameters as a file (``@PARAM/param.pck`` over
MAVLink FTP) and fall back to PARAM_REQUEST_LIST when that fails; unanswered, MAVProxy waited 11 s
before falling back (issue 10, item 3). Each request is answered as the MAVLink FTP protocol
defines: resetting or ending sessions is acknowledged (there are none), anything else is refused
with "file not found". Payload layout and codes from the MAVLink FTP specification.
"""

from __future__ import annotations

import struct

from dronefleet.protocols.mavlink.codec import Message
from dronefleet.protocols.mavlink.codec import dialect as mav

TERMINATE_SESSION, RESET_SESSIONS = 1, 2
ACK, NAK = 128, 129
FILE_NOT_FOUND = 10
_HEADER = struct.Struct("<HBBBBBBI")  # seq, session, opcode, size, req_opcode, burst, pad, offset
_PAYLOAD = 251


def answer(msg: Message) -> Message:
    """The reply to a FILE_TRANSFER_PROTOCOL request."""
    seq, session, opcode, _size, _req, _burst, _pad, offset = _HEADER.unpack_from(
        bytes(msg.payload[: _HEADER.size])
    )
    if opcode in (TERMINATE_SESSION, RESET_SESSIONS):
        reply, data = ACK, b""
    else:
        reply, data = NAK, bytes([FILE_NOT_FOUND])
    header = _HEADER.pack((seq + 1) & 0xFFFF, session, reply, len(data), opcode, 0, 0, offset)
    payload = (header + data).ljust(_PAYLOAD, b"\0")
    return mav.MAVLink_file_transfer_protocol_message(
        0, msg.get_srcSystem(), msg.get_srcComponent(), list(payload)
    )
