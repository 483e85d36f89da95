"""Fake drones for the benchmarks: raw MQTT 3.1.1 connections in one asyncio loop.

Shared by bench/broker_capacity.py (how much a broker carries) and bench/ground_capacity.py (how
much a ground carries). Each fake drone is its own TCP connection with its own credentials, as a
fleet on a ground broker is; the loop writes pre-encoded packets straight to the sockets (no
client library: a thousand paho clients in threads would measure Python, not what is under
test). A message whose stamps change at each send (``timestamp``, ``vehicle_time_s``) is encoded
once from the project's own model with marker values and joined around the new stamps at each
send (:class:`Stamped`, a few microseconds). A packet is skipped, and counted, when a drone's
socket buffer holds over :data:`SKIP_ABOVE` bytes (the broker is not reading).
"""

from __future__ import annotations

import asyncio
import dataclasses
import os
import re
import struct
import time
from collections.abc import Callable, Mapping, Sequence

HOST = "127.0.0.1"
TELEMETRY_HZ = 5
HEARTBEAT_S = 5.0
TICK_S = 0.02  # the generator writes every 20 ms: each drone's telemetry every 10th tick
KEEPALIVE_S = 300  # the drones send nothing while the others connect
SKIP_ABOVE = 64 * 1024
CONNECTING = 200  # connection attempts at once

#: Called with (topic, payload) for each PUBLISH a connection receives.
OnPublish = Callable[[str, bytes], None]

# -- MQTT 3.1.1, the few packets needed (wire format, OASIS MQTT 3.1.1 §3) --------------------


def _length(n: int) -> bytes:
    out = bytearray()
    while True:
        n, digit = divmod(n, 128)
        out.append(digit | (0x80 if n else 0))
        if not n:
            return bytes(out)


def _string(text: str | bytes) -> bytes:
    data = text.encode() if isinstance(text, str) else text
    return struct.pack("!H", len(data)) + data


def connect_packet(client_id: str, username: str, password: str) -> bytes:
    body = _string("MQTT") + bytes([4, 0xC2]) + struct.pack("!H", KEEPALIVE_S)
    body += _string(client_id) + _string(username) + _string(password)
    return b"\x10" + _length(len(body)) + body


def publish_packet(topic_name: str, payload: bytes) -> bytes:  # QoS 0, no packet id
    body = _string(topic_name) + payload
    return b"\x30" + _length(len(body)) + body


def subscribe_packet(packet_id: int, filters: list[str], qos: int = 0) -> bytes:
    body = struct.pack("!H", packet_id) + b"".join(_string(f) + bytes([qos]) for f in filters)
    return b"\x82" + _length(len(body)) + body


class Stamped:
    """A QoS 0 PUBLISH whose payload is the project's model encoded once with marker values in
    place of its stamps; :meth:`packet` joins the pieces around the stamps of this send."""

    def __init__(self, topic_name: str, encoded: bytes, marks: Mapping[bytes, int]) -> None:
        pattern = b"(" + b"|".join(re.escape(m) for m in marks) + b")"
        parts = re.split(pattern, encoded)
        if len(parts) < 3:
            raise ValueError(f"no marker in {encoded[:80]!r}")
        self._topic = _string(topic_name)
        self._literals = parts[0::2]
        self._slots = [marks[m] for m in parts[1::2]]

    def packet(self, values: Sequence[bytes]) -> bytes:
        out = [self._topic, self._literals[0]]
        for slot, literal in zip(self._slots, self._literals[1:], strict=True):
            out.append(values[slot])
            out.append(literal)
        body = b"".join(out)
        return b"\x30" + _length(len(body)) + body


# -- connections -------------------------------------------------------------------------------


class Link(asyncio.Protocol):
    """One MQTT connection: waits for its CONNACK (and SUBACK), counts PUBLISH packets in and
    hands them to ``on_publish`` when given."""

    def __init__(self, on_publish: OnPublish | None = None) -> None:
        loop = asyncio.get_running_loop()
        self.connack: asyncio.Future[int] = loop.create_future()
        self.suback: asyncio.Future[bytes] | None = None  # while a SUBSCRIBE is answered
        self.transport: asyncio.Transport | None = None
        self.buffer = bytearray()
        self.published = 0
        self.lost = False
        self.on_publish = on_publish

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.transport = transport

    def data_received(self, data: bytes) -> None:
        buf = self.buffer
        buf += data
        at, end = 0, len(buf)
        while at + 2 <= end:
            kind, size, shift, i = buf[at] >> 4, 0, 0, at + 1
            while i < end and buf[i] & 0x80:
                size |= (buf[i] & 0x7F) << shift
                shift, i = shift + 7, i + 1
            if i >= end:
                break
            size |= buf[i] << shift
            start = i + 1
            if start + size > end:
                break
            if kind == 3:
                self.published += 1
                if self.on_publish is not None:
                    self._deliver(buf[at] & 0x0F, bytes(buf[start : start + size]))
            elif kind == 2 and not self.connack.done():
                self.connack.set_result(buf[start + 1])
            elif kind == 9 and self.suback is not None and not self.suback.done():
                self.suback.set_result(bytes(buf[start + 2 : start + size]))
            at = start + size
        del buf[:at]

    def _deliver(self, flags: int, body: bytes) -> None:
        assert self.on_publish is not None
        (length,) = struct.unpack_from("!H", body)
        topic_name = body[2 : 2 + length].decode()
        payload_at = 2 + length + (2 if (flags >> 1) & 3 else 0)  # a packet id at QoS 1 and 2
        self.on_publish(topic_name, body[payload_at:])

    def connection_lost(self, exc: Exception | None) -> None:
        self.lost = True
        for waiting in (self.connack, self.suback):
            if waiting is not None and not waiting.done():
                waiting.set_exception(ConnectionError("connection closed by the broker"))


async def open_link(
    port: int, client_id: str, username: str, password: str, on_publish: OnPublish | None = None
) -> Link:
    loop = asyncio.get_running_loop()
    _, link = await loop.create_connection(lambda: Link(on_publish), HOST, port)
    assert link.transport is not None
    link.transport.write(connect_packet(client_id, username, password))
    async with asyncio.timeout(60):
        code = await link.connack
    if code != 0:
        raise ConnectionError(f"{client_id}: CONNACK return code {code}")
    return link


async def subscribe(link: Link, filters: list[str], packet_id: int = 1) -> bytes:
    """SUBSCRIBE at QoS 0 and wait for the SUBACK; its return codes (0x80: refused)."""
    assert link.transport is not None
    link.suback = asyncio.get_running_loop().create_future()
    link.transport.write(subscribe_packet(packet_id, filters))
    async with asyncio.timeout(30):
        return await link.suback


@dataclasses.dataclass
class Connected:
    links: list[Link]  # in the drones' order, those that could not connect left out
    of: dict[str, Link] = dataclasses.field(default_factory=dict)  # drone id -> its link
    failed: int = 0
    seconds: float = 0.0


async def connect_all(
    port: int,
    drones: Sequence[tuple[str, str]],
    *,
    subscriptions: Callable[[str], list[str]] | None = None,
    on_publish: Callable[[str], OnPublish] | None = None,
) -> Connected:
    """Connect every ``(drone_id, password)`` (client id ``<id>-bench``), at most
    :data:`CONNECTING` at once; each subscribes to ``subscriptions(drone_id)`` when given and
    hands what it receives to ``on_publish(drone_id)``. The links keep the drones' order; a
    drone that could not connect is left out and counted."""
    gate = asyncio.Semaphore(CONNECTING)
    result = Connected([])

    async def one(drone_id: str, password: str) -> Link | None:
        async with gate:
            try:
                handler = on_publish(drone_id) if on_publish is not None else None
                link = await open_link(port, f"{drone_id}-bench", drone_id, password, handler)
                if subscriptions is not None:
                    granted = await subscribe(link, subscriptions(drone_id))
                    if any(code & 0x80 for code in granted):
                        raise ConnectionError(f"{drone_id}: subscription refused")
                result.of[drone_id] = link
                return link
            except (OSError, ConnectionError, TimeoutError) as exc:
                if result.failed < 3:
                    print(f"  {drone_id}: {exc!r}")
                result.failed += 1
                return None

    began = time.perf_counter()
    links = await asyncio.gather(*(one(d, p) for d, p in drones))
    result.seconds = time.perf_counter() - began
    result.links = [link for link in links if link is not None]
    return result


# -- the stream ----------------------------------------------------------------------------------


@dataclasses.dataclass
class Sent:
    telemetry: int = 0
    heartbeats: int = 0
    skipped: int = 0  # telemetry not written: the drone's socket buffer was full
    window_s: float = 0.0

    @property
    def total(self) -> int:
        return self.telemetry + self.heartbeats


async def stream(
    links: Sequence[Link],
    telemetry: Callable[[int], bytes],
    heartbeat: Callable[[int], bytes],
    sent: Sent,
    *,
    seconds: float | None = None,
    stop: Callable[[], bool] | None = None,
    each_tick: Callable[[Sent], None] | None = None,
    talking: int | None = None,
) -> None:
    """Telemetry at :data:`TELEMETRY_HZ` and a heartbeat every :data:`HEARTBEAT_S` per drone,
    spread over the ticks, for ``seconds`` or until ``stop()``. ``telemetry(i)`` and
    ``heartbeat(i)`` give drone ``i``'s next packet. Only the first ``talking`` drones (all
    when None) send telemetry; the others only heartbeats."""
    talkers = len(links) if talking is None else talking
    period = round(1 / TELEMETRY_HZ / TICK_S)  # ticks between one drone's telemetry
    beat = round(HEARTBEAT_S / TICK_S)
    loop = asyncio.get_running_loop()
    began = loop.time()
    tick = 0
    while (seconds is None or tick * TICK_S < seconds) and not (stop is not None and stop()):
        delay = began + tick * TICK_S - loop.time()
        if delay > 0:
            await asyncio.sleep(delay)
        for i in range(tick % period, talkers, period):
            transport = links[i].transport
            assert transport is not None
            if transport.is_closing() or transport.get_write_buffer_size() > SKIP_ABOVE:
                sent.skipped += 1
                continue
            transport.write(telemetry(i))
            sent.telemetry += 1
        for i in range(tick % beat, len(links), beat):
            transport = links[i].transport
            assert transport is not None
            if not transport.is_closing():
                transport.write(heartbeat(i))
                sent.heartbeats += 1
        if each_tick is not None:
            each_tick(sent)
        tick += 1
    sent.window_s = loop.time() - began


# -- processes -----------------------------------------------------------------------------------


def proc_cpu_s(pid: int) -> float:
    """CPU seconds (utime + stime, every thread) of process ``pid``."""
    with open(f"/proc/{pid}/stat") as stat:
        fields = stat.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def proc_rss_mb(pid: int) -> tuple[float, float]:
    """(VmRSS, VmHWM) in MB."""
    values = {}
    with open(f"/proc/{pid}/status") as status:
        for line in status:
            key, _, rest = line.partition(":")
            if key in ("VmRSS", "VmHWM"):
                values[key] = int(rest.split()[0]) / 1024
    return values["VmRSS"], values["VmHWM"]
