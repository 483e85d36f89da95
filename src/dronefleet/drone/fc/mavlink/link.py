"""The MAVLink link to one autopilot, wrapped for asyncio (Flight Controller Interface, seed
3.3.2.2 / 4.1.2.1).

pymavlink's ``mavutil.mavlink_connection`` opens UDP, TCP or serial; nothing here blocks the event
loop: the connection is opened in a worker thread, and the socket or serial port is read from a
loop reader callback (``recv_match(blocking=False)`` until drained) as soon as it is readable.
The link keeps the latest message of every type, fans messages out to listeners, sends a ground
station HEARTBEAT every second of the autopilot's clock (:data:`GCS_BEAT_VEHICLE_S`; 4 times a
wall second at least) and watches the autopilot's heartbeats: silence for ``heartbeat_timeout_s``
marks the link lost (commands then fail with that reason); TCP and serial links are reopened, UDP
links recover by themselves as soon as heartbeats come back.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable
from typing import Any

from pymavlink import mavutil

from dronefleet.clock import monotonic
from dronefleet.errors import Unavailable
from dronefleet.protocols.mavlink.codec import Message, enable_signing, text_field
from dronefleet.protocols.mavlink.codec import dialect as mav

log = logging.getLogger(__name__)

Listener = Callable[[Message], None]

#: Our identity on the link: a ground station's system id and the mission planner component.
GCS_SYSTEM_ID = 255
GCS_COMPONENT_ID = mav.MAV_COMP_ID_MISSIONPLANNER
#: Messages handled per reader callback before yielding to other tasks.
_MAX_BATCH = 500
#: Vehicle seconds between our HEARTBEATs (issue 26). The autopilot's GCS failsafe counts its
#: timeout on its own clock (ArduPilot FS_GCS_TIMEOUT, 5 s by default; PX4 COM_DL_LOSS_T, 10 s;
#: drone/fc/mavlink/gcs_failsafe.py), so a simulated autopilot running 5 times faster than the
#: wall clock must hear us every 0.2 wall s: once a wall second it tripped on a live drone.
GCS_BEAT_VEHICLE_S = 1.0
#: Wall seconds between our HEARTBEATs, at most and at least (a simulation run very fast). At
#: most 0.25: until the autopilot's clock has shown its rate (its first stamps) it is taken as
#: the wall's, and a simulation 5 times faster tripped its failsafe in that first second.
_MAX_BEAT_WALL_S = 0.25
_MIN_BEAT_WALL_S = 0.01


class LinkLost(Unavailable, RuntimeError):
    pass


class MavlinkLink:
    """One autopilot over one pymavlink connection."""

    def __init__(
        self,
        url: str,
        *,
        source_system: int = GCS_SYSTEM_ID,
        source_component: int = GCS_COMPONENT_ID,
        target_system: int | None = None,
        heartbeat_timeout_s: float = 3.0,
        baud: int = 57600,
        signing_key: bytes | None = None,
    ) -> None:
        self.url = url
        self.signing_key = signing_key
        self.source_system = source_system
        self.source_component = source_component
        self.target_system = target_system
        self.target_component = mav.MAV_COMP_ID_AUTOPILOT1
        self.heartbeat_timeout_s = heartbeat_timeout_s
        self.baud = baud
        self.latest: dict[str, Message] = {}
        self.received_wall: dict[str, float] = {}
        self.last_heartbeat_wall: float | None = None
        self.link_ok = False
        self.parse_errors = 0
        self.statustexts: list[tuple[float, int, str]] = []  # (wall, severity, text)
        self._chunks: dict[int, list[str]] = {}
        self._listeners: list[Listener] = []
        self._state_listeners: list[Callable[[bool], None]] = []
        self._conn: Any = None
        self._fd: int | None = None
        self._tasks: list[asyncio.Task[None]] = []
        self._closed = False
        self._reopening = False
        #: The autopilot's vehicle seconds per wall second (its clock's estimate; the
        #: controller sets it), which paces our heartbeats.
        self.vehicle_rate: Callable[[], float] = lambda: 1.0

    # -- lifecycle ----------------------------------------------------------------------------
    async def open(self) -> None:
        self._closed = False
        self._tasks = []
        await self._open_connection()
        loop = asyncio.get_running_loop()
        self._tasks += [
            loop.create_task(self._send_heartbeats(), name="mavlink-gcs-heartbeat"),
            loop.create_task(self._watchdog(), name="mavlink-watchdog"),
        ]

    async def _open_connection(self) -> None:
        conn = await asyncio.to_thread(
            mavutil.mavlink_connection,
            self.url,
            baud=self.baud,
            source_system=self.source_system,
            source_component=self.source_component,
        )
        # Speak MAVLink 2 from the first byte with our own parser (mavutil would otherwise start in
        # MAVLink 1 and switch process-wide through an environment variable).
        conn.mav = mav.MAVLink(
            conn, srcSystem=self.source_system, srcComponent=self.source_component
        )
        conn.mav.robust_parsing = True
        if self.signing_key is not None:
            # Signed both ways: the autopilot ignores what we send unsigned, and we ignore
            # whatever reaches this port without the key (issue 12).
            enable_signing(conn.mav, self.signing_key)
        conn.first_byte = False
        conn.WIRE_PROTOCOL_VERSION = "2.0"
        self._conn = conn
        self._fd = getattr(conn, "fd", None)
        if self._fd is not None:
            asyncio.get_running_loop().add_reader(self._fd, self._on_readable)
        else:  # e.g. a log file or an exotic transport: poll
            self._tasks.append(asyncio.get_running_loop().create_task(self._poll()))

    async def close(self) -> None:
        self._closed = True
        for task in self._tasks:
            task.cancel()
        for task in self._tasks:
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
        self._tasks = []
        self._close_connection()
        self._set_link(False)

    def _close_connection(self) -> None:
        if self._fd is not None:
            with contextlib.suppress(Exception):
                asyncio.get_running_loop().remove_reader(self._fd)
            self._fd = None
        if self._conn is not None:
            with contextlib.suppress(Exception):
                self._conn.close()
            self._conn = None

    # -- receiving ----------------------------------------------------------------------------
    def _on_readable(self) -> None:
        conn = self._conn
        for _ in range(_MAX_BATCH):
            try:
                msg = conn.recv_match(blocking=False)
            except OSError as exc:  # a dead TCP peer, a vanished serial port
                log.warning("MAVLink link %s failed: %s", self.url, exc)
                self._close_connection()
                self._set_link(False)
                return
            except Exception as exc:  # hostile bytes the parser choked on: drop them
                log.debug("MAVLink parser reset on %s: %s", self.url, exc)
                self.parse_errors += 1
                conn.mav.buf, conn.mav.buf_index = bytearray(), 0
                conn.mav.expected_length = mav.HEADER_LEN_V1 + 2
                continue
            if msg is None:
                return
            self._dispatch(msg)

    async def _poll(self) -> None:
        while not self._closed:
            if self._conn is not None:
                self._on_readable()
            await asyncio.sleep(0.005)

    def _dispatch(self, msg: Message) -> None:
        kind = msg.get_type()
        if kind == "BAD_DATA" or isinstance(msg, mav.MAVLink_unknown):
            self.parse_errors += 1
            return
        src = msg.get_srcSystem()
        if kind == "HEARTBEAT" and msg.type != mav.MAV_TYPE_GCS:
            if msg.autopilot == mav.MAV_AUTOPILOT_INVALID:
                return  # a gimbal, a radio: not the autopilot
            if self.target_system is None:
                self.target_system = src
                self.target_component = msg.get_srcComponent()
            if src == self.target_system:
                self.last_heartbeat_wall = monotonic()
                self._set_link(True)
        if src != self.target_system:
            return
        now = monotonic()
        self.latest[kind] = msg
        self.received_wall[kind] = now
        if kind == "STATUSTEXT":
            self._on_statustext(msg, now)
        for listener in list(self._listeners):
            try:
                listener(msg)
            except Exception:
                log.exception("MAVLink listener failed on %s", kind)

    def _on_statustext(self, msg: Message, wall: float) -> None:
        text = text_field(msg.text)
        msg_id = getattr(msg, "id", 0)
        if msg_id:  # MAVLink 2 long text in chunks; a chunk shorter than 50 ends it
            parts = self._chunks.setdefault(msg_id, [])
            parts.append(text)
            if len(text) >= 50:
                return
            text = "".join(self._chunks.pop(msg_id))
        self.statustexts.append((wall, msg.severity, text))
        del self.statustexts[:-50]
        log.info("autopilot %s says: %s", self.target_system, text)

    def add_listener(self, listener: Listener) -> Callable[[], None]:
        self._listeners.append(listener)
        return lambda: self._listeners.remove(listener) if listener in self._listeners else None

    def on_link_change(self, callback: Callable[[bool], None]) -> None:
        self._state_listeners.append(callback)

    async def wait_for(
        self,
        kinds: str | tuple[str, ...],
        predicate: Callable[[Message], bool] | None = None,
        timeout_s: float = 2.0,
    ) -> Message | None:
        """The next message of one of ``kinds`` matching ``predicate`` (wall timeout; None)."""
        kinds = (kinds,) if isinstance(kinds, str) else kinds
        future: asyncio.Future[Message] = asyncio.get_running_loop().create_future()

        def match(msg: Message) -> None:
            if (
                not future.done()
                and msg.get_type() in kinds
                and (predicate is None or predicate(msg))
            ):
                future.set_result(msg)

        remove = self.add_listener(match)
        try:
            async with asyncio.timeout(timeout_s):
                return await future
        except TimeoutError:
            return None
        finally:
            remove()

    def reason_since(self, wall: float) -> str | None:
        """The latest warning (or worse) STATUSTEXT received after ``wall``: the autopilot's
        reason for a refusal. Informational texts (ArduPilot's "EKF3 IMU1 ... yaw alignment
        complete" arrives just after take-off) are news, not reasons."""
        for when, severity, text in reversed(self.statustexts):
            if when < wall:
                break
            if severity <= mav.MAV_SEVERITY_WARNING:
                return text
        return None

    def failsafe_since(self, wall: float) -> str | None:
        """The latest STATUSTEXT after ``wall`` announcing a failsafe or a fence breach: how
        ArduPilot says it changed the mode itself ("Battery Failsafe", "GCS Failsafe")."""
        for when, _severity, text in reversed(self.statustexts):
            if when < wall:
                break
            if "failsafe" in text.lower() or "fence" in text.lower():
                return text
        return None

    # -- sending ------------------------------------------------------------------------------
    def send(self, message: Message) -> None:
        if self._conn is None:
            raise LinkLost(f"no MAVLink connection to {self.url}")
        try:
            self._conn.mav.send(message)
        except OSError as exc:
            raise LinkLost(f"cannot send to {self.url}: {exc}") from exc

    async def _send_heartbeats(self) -> None:
        beat = mav.MAVLink_heartbeat_message(
            mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, mav.MAV_STATE_ACTIVE, 3
        )
        while True:
            with contextlib.suppress(LinkLost):
                self.send(beat)
            await asyncio.sleep(self.beat_period_s())

    def beat_period_s(self) -> float:
        """Wall seconds to our next HEARTBEAT: :data:`GCS_BEAT_VEHICLE_S` of the autopilot's
        time, within :data:`_MIN_BEAT_WALL_S` and :data:`_MAX_BEAT_WALL_S`."""
        try:
            rate = float(self.vehicle_rate())
        except Exception:  # a clock that cannot tell: the wall clock's second
            rate = 1.0
        if not rate > 0:
            return _MAX_BEAT_WALL_S
        return min(_MAX_BEAT_WALL_S, max(_MIN_BEAT_WALL_S, GCS_BEAT_VEHICLE_S / rate))

    # -- watchdog -----------------------------------------------------------------------------
    def heartbeat_age_s(self) -> float | None:
        if self.last_heartbeat_wall is None:
            return None
        return monotonic() - self.last_heartbeat_wall

    def describe(self) -> str:
        age = self.heartbeat_age_s()
        if age is None:
            return f"no heartbeat yet from the autopilot at {self.url}"
        return f"autopilot at {self.url}: last heartbeat {age:.1f} s ago"

    def _set_link(self, ok: bool) -> None:
        if ok == self.link_ok:
            return
        self.link_ok = ok
        level = logging.INFO if ok or self._closed else logging.WARNING
        log.log(level, "MAVLink link to %s %s", self.url, "up" if ok else "lost")
        for callback in list(self._state_listeners):
            try:
                callback(ok)
            except Exception:
                log.exception("link state listener failed")

    async def _watchdog(self) -> None:
        lost_since: float | None = None
        while True:
            await asyncio.sleep(0.25)
            age = self.heartbeat_age_s()
            if age is not None and age > self.heartbeat_timeout_s:
                self._set_link(False)
            if self.link_ok:
                lost_since = None
                continue
            lost_since = lost_since or monotonic()
            stream = not self.url.startswith(("udp", "mcast"))
            if (self._conn is None or stream) and monotonic() - lost_since > 2.0:
                await self._reopen()
                lost_since = monotonic()

    async def _reopen(self) -> None:
        """Reopen a TCP/serial connection (UDP needs none: the autopilot just talks again)."""
        if self._reopening or self._closed:
            return
        self._reopening = True
        try:
            self._close_connection()
            await self._open_connection()
            log.info("MAVLink link to %s reopened", self.url)
        except Exception as exc:
            log.warning("reopening MAVLink link %s failed: %s", self.url, exc)
        finally:
            self._reopening = False
