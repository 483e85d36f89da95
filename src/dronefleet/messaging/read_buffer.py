"""Buffered reads for paho's socket: many MQTT packets per system call and per wake-up.

paho (2.2) reads each packet in three or more ``recv`` calls on its socket (the command byte,
each byte of the remaining length, then the rest), and aiomqtt calls paho's ``loop_read`` once
each time the event loop finds the socket readable: a system call or three and a turn of the
event loop for every message. At 5 Hz telemetry from a thousand drones that was a third of the
cost of receiving a message (bench: 23 us of CPU per message through a broker client with a
handler that does nothing; 12.5-13 us with these reads).

:class:`BufferedSocket` is what paho's own websocket transport is (``_WebsocketWrapper``): an
object with paho's ``SocketLike`` methods (``recv``, ``send``, ``close``, ``fileno``,
``setblocking``) around the socket, reading up to :data:`READ_BYTES` at a time and handing out
what paho asks for from that. Its ``pending()`` says how much is held, and aiomqtt's reader calls
``loop_read`` again while ``pending()`` is above zero (as it does for an ``SSLSocket``'s decrypted
bytes), so nothing held waits for the socket to be readable again. TLS sockets are wrapped the
same way: their ``SSLWantReadError`` passes through to paho, which handles it.

One turn of the event loop takes one read's packets, no more: the socket is read ahead only for
a packet's first byte, and a packet the read ended in is finished with a read of just its rest,
so the turn ends there. Reading ahead for that rest too let one connection's backlog be read
whole in a turn, while the others (the ground's heartbeats have a connection of their own, so
that they never wait for telemetry: ground/inbox.py) waited.
"""

from __future__ import annotations

from typing import Any

import aiomqtt

#: Bytes read from the socket at a time (a few hundred telemetry messages).
READ_BYTES = 64 * 1024


class BufferedSocket:
    """``sock`` read :data:`READ_BYTES` at a time; any other attribute is the socket's."""

    def __init__(self, sock: Any) -> None:
        self._sock = sock
        self._held = b""
        self._at = 0  # where the bytes not yet handed out start in _held

    def recv(self, size: int) -> bytes:
        held, at = self._held, self._at
        if at >= len(held):
            if size > 1:
                # The rest of a packet the last read ended in: only that, so that this turn of
                # the event loop ends with the packet and the other connections get theirs.
                return bytes(self._sock.recv(size))
            data: bytes = self._sock.recv(READ_BYTES)  # a new packet's first byte: read ahead
            if len(data) <= size:  # all of it (or b"" at the end of the stream)
                return data
            self._held, self._at = data, size
            return data[:size]
        end = min(at + size, len(held))  # a short read when less is held, as recv may give
        self._at = end
        return held[at:end]

    def pending(self) -> int:
        """Bytes held here, and those a TLS socket has decrypted but not handed out."""
        inner = getattr(self._sock, "pending", None)
        return len(self._held) - self._at + (inner() if inner is not None else 0)

    def send(self, data: bytes | bytearray) -> int:
        return int(self._sock.send(data))

    def close(self) -> None:
        self._sock.close()

    def fileno(self) -> int:
        return int(self._sock.fileno())

    def setblocking(self, flag: bool) -> None:
        self._sock.setblocking(flag)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._sock, name)  # setsockopt, getpeername, ...


def read_buffered(connection: aiomqtt.Client) -> None:
    """Make ``connection``'s paho client read through a :class:`BufferedSocket` (set before it
    connects). aiomqtt gives no handle on paho's socket factory; paho's is its own method."""
    paho: Any = connection._client
    make = paho._create_socket

    def create_socket() -> BufferedSocket:
        return BufferedSocket(make())

    paho._create_socket = create_socket
