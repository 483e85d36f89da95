"""Simulated dRonin flight controllers served over UAVTalk on TCP.

Each vehicle of a :class:`~dronefleet.sim.world.SimWorld` gets its own TCP port, as a real board
gets its own USB link to its Raspberry Pi (seed Figure 4.11). On every connection the flight side
behaves like dRonin's telemetry module:

* objects whose definition says ``telemetryflight updatemode="periodic"`` are sent at their
  period in vehicle seconds (GPSPosition 5 Hz, AttitudeActual 10 Hz, ...), so a world running
  20 times faster than real time sends them 20 times as often; FlightStatus is also sent at once
  whenever it changes;
* OBJ_REQ is answered with the object (NACK if unknown); OBJ_ACK writes are carried out and
  ACKed, or NACKed after a ``FlightCommandStatus`` with the vehicle's reason; plain OBJ writes are
  carried out silently; a repeated FlightCommand ``Sequence`` is answered again, not re-executed.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from typing import Any

from dronefleet.protocols.uavtalk.framing import Frame, FrameParser, MessageType, encode_frame
from dronefleet.protocols.uavtalk.objects import ObjectDef
from dronefleet.protocols.uavtalk.registry import ObjectRegistry, default_registry
from dronefleet.sim.uavtalk.vehicle_objects import VehicleObjects
from dronefleet.sim.world import SimWorld
from dronefleet.vehicle.base import FcError

log = logging.getLogger(__name__)

#: Periodic updates are checked this often (vehicle seconds): one physics step.
_TICK_S = 0.05
#: Stop queueing periodic updates for a client this far behind (bytes).
_MAX_BACKLOG_BYTES = 1 << 20
_STATUS = "FlightCommandStatus"
_REASON_BYTES = 120


class UAVTalkServer:
    """``async with UAVTalkServer(world, port=9000) as server: server.endpoints``"""

    def __init__(
        self,
        world: SimWorld,
        vehicle_ids: list[str] | None = None,
        *,
        host: str = "127.0.0.1",
        port: int = 0,
        registry: ObjectRegistry | None = None,
    ) -> None:
        """Vehicle ``i`` listens on ``port + i`` (``port=0``: any free port for each)."""
        self.world = world
        self.vehicle_ids = list(vehicle_ids if vehicle_ids is not None else world.vehicles)
        self.host, self.port = host, port
        self.registry = registry or default_registry()
        self.endpoints: dict[str, str] = {}
        self._servers: list[asyncio.Server] = []
        self._sessions: set[_Session] = set()

    async def start(self) -> None:
        for i, vid in enumerate(self.vehicle_ids):
            objects = VehicleObjects(self.world.vehicles[vid], self.registry)

            async def handle(reader, writer, objects=objects):
                session = _Session(objects, self.world, reader, writer)
                self._sessions.add(session)
                try:
                    await session.run()
                finally:
                    self._sessions.discard(session)

            port = self.port + i if self.port else 0
            server = await asyncio.start_server(handle, self.host, port)
            self._servers.append(server)
            bound = server.sockets[0].getsockname()[1]
            self.endpoints[vid] = f"tcp:{self.host}:{bound}"
            log.info("UAVTalk vehicle %s on %s", vid, self.endpoints[vid])

    async def stop(self) -> None:
        """Stop listening and hang up on every client (each session then ends on its own)."""
        for server in self._servers:
            server.close()
        for session in list(self._sessions):
            session.hang_up()
        for _ in range(100):  # sessions end at their next read, within a loop iteration or two
            if not self._sessions:
                break
            await asyncio.sleep(0.01)
        for server in self._servers:
            with contextlib.suppress(Exception):
                async with asyncio.timeout(1.0):
                    await server.wait_closed()
        self._servers.clear()

    async def __aenter__(self) -> UAVTalkServer:
        await self.start()
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.stop()


class _Session:
    """One ground connection to one simulated flight controller."""

    def __init__(
        self,
        objects: VehicleObjects,
        world: SimWorld,
        reader: asyncio.StreamReader,
        writer: asyncio.StreamWriter,
    ) -> None:
        self.objects = objects
        self.registry = objects.registry
        self.clock = world.clock
        self.reader, self.writer = reader, writer
        self.parser = FrameParser(self.registry.multi_instance)
        self._last_command: tuple[int, bytes, bool] | None = None  # (sequence, data, accepted)

    async def run(self) -> None:
        periodic = asyncio.create_task(self._periodic())
        try:
            while chunk := await self.reader.read(4096):
                for frame in self.parser.feed(chunk):
                    self._handle(frame)
        except (ConnectionError, OSError):
            pass
        finally:
            periodic.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await periodic
            self.writer.close()

    def hang_up(self) -> None:
        self.writer.close()

    # -- sending -------------------------------------------------------------------------------
    def _send(self, kind: MessageType, definition: ObjectDef, instance: int = 0, data=b"") -> None:
        if self.writer.is_closing():
            return
        frame = Frame(kind, definition.id, instance, data)
        self.writer.write(encode_frame(frame, multi_instance=not definition.single_instance))

    def _send_object(self, name: str, instance: int = 0) -> bool:
        data = self.objects.packed(name, instance)
        if data is None:
            return False
        self._send(MessageType.OBJ, self.registry[name], instance, data)
        return True

    async def _periodic(self) -> None:
        schedule = [
            (d.name, d.flight_period_ms / 1000.0)
            for d in self.objects.served()
            if d.flight_update_mode == "periodic" and d.flight_period_ms > 0
        ]
        due = dict.fromkeys((name for name, _ in schedule), self.clock.now())
        last_status = None
        self._send_object("HomeLocation")
        while True:
            now = self.clock.now()
            backlog = self.writer.transport.get_write_buffer_size()
            for name, period_s in schedule:
                if now >= due[name] - 1e-9 and backlog < _MAX_BACKLOG_BYTES:
                    self._send_object(name)
                    due[name] = max(due[name] + period_s, now)
            status = self.objects.packed("FlightStatus")
            if status != last_status:
                self._send_object("FlightStatus")
                last_status = status
            await self.clock.sleep(_TICK_S)

    # -- receiving -----------------------------------------------------------------------------
    def _handle(self, frame: Frame) -> None:
        definition = self.registry.by_id.get(frame.object_id)
        kind = frame.type
        if kind is MessageType.OBJ_REQ:
            if definition is None or not self._send_object(definition.name, frame.instance_id):
                self._nack(frame.object_id)
        elif kind.carries_data:
            acked = kind in (MessageType.OBJ_ACK, MessageType.OBJ_ACK_TS)
            if definition is None:
                if acked:
                    self._nack(frame.object_id)
                return
            self._write(definition, frame, acked)
        # ACK and NACK: the flight side sends nothing that waits for them.

    def _write(self, definition: ObjectDef, frame: Frame, acked: bool) -> None:
        try:
            values = definition.decode(frame.data)
        except ValueError as exc:
            self._answer(definition, frame, acked, False, f"malformed: {exc}")
            return
        sequence = values.get("Sequence", 0) if definition.name == "FlightCommand" else 0
        last = self._last_command
        if sequence and last is not None and last[:2] == (sequence, frame.data):
            self._answer(definition, frame, acked, last[2], "repeated command", sequence)
            return
        try:
            self.objects.apply(definition.name, frame.instance_id, values)
        except FcError as exc:
            accepted, reason = False, str(exc)
        else:
            accepted, reason = True, ""
        if sequence:
            self._last_command = (sequence, frame.data, accepted)
        self._answer(definition, frame, acked, accepted, reason, sequence)

    def _answer(
        self,
        definition: ObjectDef,
        frame: Frame,
        acked: bool,
        accepted: bool,
        reason: str,
        sequence: int = 0,
    ) -> None:
        if not acked:
            if not accepted:
                log.info("%s write refused: %s", definition.name, reason)
            return
        if _STATUS in self.registry:
            status: dict[str, Any] = {
                "ObjectID": definition.id,
                "InstanceID": frame.instance_id,
                "Sequence": sequence,
                "Result": "Accepted" if accepted else "Refused",
                "Reason": reason.encode("ascii", "replace")[:_REASON_BYTES],
            }
            status_def = self.registry[_STATUS]
            self._send(MessageType.OBJ, status_def, 0, status_def.encode(status))
        if accepted:
            self._send_object("FlightStatus")  # the new state reaches the ground before the ACK
            self._send(MessageType.ACK, definition, frame.instance_id)
        else:
            self._nack(definition.id)

    def _nack(self, object_id: int) -> None:
        if self.writer.is_closing():
            return
        self.writer.write(encode_frame(Frame(MessageType.NACK, object_id)))
