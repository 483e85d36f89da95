"""One simulated vehicle on its own UDP port, speaking MAVLink 2 as an ArduPilot Copter would.

Any ground station that sends a datagram to the port becomes a peer and receives the vehicle's
telemetry (several at once: our drone backend and, say, QGroundControl). As ArduPilot does, it
keeps streaming to a peer that has gone quiet (issue 10, item 8: streams used to stop 9.9 s after
the ground station stopped sending); only the :data:`MAX_PEERS` most recently heard are kept.
Incoming datagrams are decoded one by one (a bad one is counted
and dropped) and dispatched: commands, SET_MODE, GUIDED targets, the mission and parameter
protocols. :meth:`VehicleEndpoint.update` runs on the sim clock — mode logic, then whatever
telemetry is due — so a sped-up world streams in vehicle time. While the vehicle reboots it is
silent, as a real autopilot is.
"""

from __future__ import annotations

import asyncio
import logging
from typing import Any

from dronefleet.clock import monotonic
from dronefleet.protocols.mavlink.codec import Encoder, FrameDecoder, Message, text_field
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.sim.gasfield import GasSensor
from dronefleet.sim.mavlink import ftp
from dronefleet.sim.mavlink.copter import CopterEvents, SimCopter
from dronefleet.sim.mavlink.handlers import CommandHandler
from dronefleet.sim.mavlink.streams import BUILDERS, StreamScheduler
from dronefleet.sim.mavlink.transfer import MissionTransfer

log = logging.getLogger(__name__)

#: Ground stations streamed to at once (the most recently heard).
MAX_PEERS = 8

_STATUSTEXT_LEN = 50
#: Bytes of MAVLink frames packed into one datagram when a burst goes out (the parameter list):
#: under a typical MTU, and few enough datagrams that no socket buffer overflows.
_BURST_BYTES = 1400
_POSITION_TARGET = mav.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT


class VehicleEndpoint(asyncio.DatagramProtocol, CopterEvents):
    """The MAVLink face of one :class:`SimCopter` (system id ``system_id``, component 1)."""

    def __init__(
        self,
        copter: SimCopter,
        system_id: int,
        host: str,
        port: int,
        *,
        gas_sensor: GasSensor | None = None,
        signing_key: bytes | None = None,
    ) -> None:
        self.copter = copter
        copter.events = self
        copter.params.set("SYSID_THISMAV", system_id)
        self.system_id = system_id
        self.host, self.port = host, port
        self.gas_sensor = gas_sensor
        self.peers: dict[tuple[str, int], float] = {}
        self.streams = StreamScheduler()
        self.commands = CommandHandler(self)
        self.transfer = MissionTransfer(copter, self.send)
        # With a key, everything sent is signed and anything not signed with it is ignored, as
        # ArduPilot does once signing is set up (only RADIO_STATUS passes unsigned).
        self._encoder = Encoder(system_id, mav.MAV_COMP_ID_AUTOPILOT1, signing=signing_key)
        self._decoder = FrameDecoder(signing=signing_key)
        self._transport: asyncio.DatagramTransport | None = None
        self._text_id = 0
        self._was_rebooting = False
        self._last_state: tuple[object, ...] = ()

    @property
    def url(self) -> str:
        return f"udp:{self.host}:{self.port}"

    @property
    def decode_errors(self) -> int:
        return self._decoder.errors

    @property
    def unsigned_dropped(self) -> int:
        """Frames ignored for a missing, wrong or replayed signature."""
        return self._decoder.unsigned

    async def start(self) -> None:
        loop = asyncio.get_running_loop()
        self._transport, _ = await loop.create_datagram_endpoint(
            lambda: self, local_addr=(self.host, self.port)
        )

    def close(self) -> None:
        if self._transport is not None:
            self._transport.close()
            self._transport = None

    # -- receiving ----------------------------------------------------------------------------
    def datagram_received(self, data: bytes, addr: tuple[str, int]) -> None:
        self.peers[addr] = monotonic()
        if len(self.peers) > MAX_PEERS:  # the one heard longest ago makes room
            del self.peers[min(self.peers, key=self.peers.__getitem__)]
        if self.copter.vehicle.rebooting:
            return
        for msg in self._decoder.feed_datagram(data):
            try:
                self._handle(msg)
            except Exception:  # a component never dies on input
                log.exception("vehicle %d: handling %s failed", self.system_id, msg.get_type())

    def error_received(self, exc: Exception) -> None:
        log.debug("vehicle %d: %s", self.system_id, exc)  # e.g. a peer's port closed

    def _handle(self, msg: Message) -> None:
        target = getattr(msg, "target_system", 0)
        if target not in (0, self.system_id):
            return
        kind = msg.get_type()
        if kind == "HEARTBEAT":
            mygcs = int(self.copter.params.get("SYSID_MYGCS"))
            if msg.type == mav.MAV_TYPE_GCS and msg.get_srcSystem() == mygcs:
                self.copter.gcs_heard()  # its GCS failsafe's clock (SimCopter)
            return
        if kind in ("COMMAND_LONG", "COMMAND_INT"):
            result, reason = self.commands.command(msg)
            self._answer(msg.command, result, reason, msg)
        elif kind == "SET_MODE":
            result, reason = self.commands.set_mode_message(msg)
            self._answer(mav.MAV_CMD_DO_SET_MODE, result, reason, msg)
        elif kind in ("SET_POSITION_TARGET_GLOBAL_INT", "SET_POSITION_TARGET_LOCAL_NED"):
            if kind == "SET_POSITION_TARGET_GLOBAL_INT":
                reason = self.commands.position_target(msg)
            else:
                reason = self.commands.local_target(msg)
            if reason:
                self.statustext(mav.MAV_SEVERITY_WARNING, reason)
            else:
                self.send_now(_POSITION_TARGET)
        elif kind == "REQUEST_DATA_STREAM":
            self.streams.request_data_stream(
                msg.req_stream_id, msg.req_message_rate, bool(msg.start_stop)
            )
        elif kind.startswith("PARAM_"):
            self._param(msg)
        elif kind == "FILE_TRANSFER_PROTOCOL":
            self.send(ftp.answer(msg))
        else:
            self.transfer.handle(msg)

    def _answer(self, command: int, result: int, reason: str | None, msg: Message) -> None:
        if reason:
            self.statustext(mav.MAV_SEVERITY_CRITICAL, reason)
        self.send(
            mav.MAVLink_command_ack_message(
                command, result, 0, 0, msg.get_srcSystem(), msg.get_srcComponent()
            )
        )
        self.send_now(mav.MAVLINK_MSG_ID_HEARTBEAT)  # state changes show at once

    def _param(self, msg: Message) -> None:
        params = self.copter.params
        kind = msg.get_type()
        if kind == "PARAM_REQUEST_LIST":  # all at once, not paced (issue 10, item 3)
            self.send_burst([params.message(name) for name in params.names()])
        elif kind == "PARAM_REQUEST_READ":
            name = text_field(msg.param_id)
            if msg.param_index >= 0:
                answer = params.message_at(msg.param_index)
            else:
                answer = params.message(name) if name in params.names() else None
            if answer is not None:
                self.send(answer)
        elif kind == "PARAM_SET":
            name = text_field(msg.param_id)
            if params.set(name, msg.param_value):
                self.send(params.message(name))
            else:
                self.statustext(mav.MAV_SEVERITY_WARNING, f"Param {name} unknown")

    # -- sending ------------------------------------------------------------------------------
    def send(self, msg: Message) -> None:
        if self._transport is None or not self.peers:
            return
        data = self._encoder.pack(msg)
        for addr in list(self.peers):
            self._transport.sendto(data, addr)

    def send_burst(self, msgs: list[Message]) -> None:
        """Many messages at once, several frames to a datagram (ground stations parse every
        frame in a datagram, as they must for ArduPilot's UDP links)."""
        if self._transport is None or not self.peers:
            return
        datagrams, chunk = [], b""
        for msg in msgs:
            frame = self._encoder.pack(msg)
            if chunk and len(chunk) + len(frame) > _BURST_BYTES:
                datagrams.append(chunk)
                chunk = b""
            chunk += frame
        datagrams.append(chunk)
        for addr in list(self.peers):
            for data in datagrams:
                self._transport.sendto(data, addr)

    def send_now(self, msg_id: int) -> bool:
        build = BUILDERS.get(msg_id)
        if build is None:
            return False
        msg = build(self.copter, self.gas_sensor)
        if msg is not None:
            self.send(msg)
        return True

    # -- CopterEvents -------------------------------------------------------------------------
    def statustext(self, severity: int, text: str) -> None:
        """STATUSTEXT; longer than 50 characters goes in MAVLink 2 chunks sharing an id."""
        raw = text.encode("utf-8")[:200]
        if len(raw) <= _STATUSTEXT_LEN:
            self.send(mav.MAVLink_statustext_message(severity, raw, 0, 0))
            return
        self._text_id = self._text_id % 65535 + 1
        chunks = [raw[i : i + _STATUSTEXT_LEN] for i in range(0, len(raw), _STATUSTEXT_LEN)]
        if len(chunks[-1]) == _STATUSTEXT_LEN:
            chunks.append(b"")  # a short (empty) chunk ends the text
        for seq, chunk in enumerate(chunks):
            self.send(mav.MAVLink_statustext_message(severity, chunk, self._text_id, seq))

    def mission_current(self, seq: int) -> None:
        self.send_now(mav.MAVLINK_MSG_ID_MISSION_CURRENT)

    def item_reached(self, seq: int) -> None:
        self.send(mav.MAVLink_mission_item_reached_message(seq))

    def captured(self, info: dict[str, Any]) -> None:
        c = self.copter
        self.send(
            mav.MAVLink_camera_image_captured_message(
                c.boot_ms(), 0, 0, round(info["lat"] * 1e7), round(info["lon"] * 1e7),
                round(info["alt_m"] * 1000), round(info["relative_alt_m"] * 1000), [1, 0, 0, 0],
                info["index"], 1, (info.get("file") or "").encode()[:205],
            )
        )  # fmt: skip

    # -- the loop -----------------------------------------------------------------------------
    def update(self) -> None:
        """Mode logic, then whatever telemetry is due (called on the sim clock)."""
        copter = self.copter
        copter.update()
        if copter.vehicle.rebooting:
            self._was_rebooting = True
            return
        if self._was_rebooting:  # a rebooted autopilot forgets the rates it was asked for
            self._was_rebooting = False
            self.streams.reset()
        self.transfer.tick()
        if not self.peers:
            return
        v = copter.vehicle
        state = (v.armed, copter.mode, v.in_air, v.landing, v.battery_failsafe)
        if state != self._last_state:  # armed, landed, mode changed: say so at once
            self._last_state = state
            self.send_now(mav.MAVLINK_MSG_ID_HEARTBEAT)
            self.send_now(mav.MAVLINK_MSG_ID_EXTENDED_SYS_STATE)
        for msg_id in self.streams.due(v.time_s):
            self.send_now(msg_id)
