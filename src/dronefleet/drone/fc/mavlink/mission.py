"""Missions on board: upload, download and progress over the MAVLink mission protocol.

The same transfers carry the geofence and the rally points (``mission_type`` FENCE and RALLY,
drone/autopilot_fence.py); only the mission has ArduPilot's home item at seq 0.

Upload: MISSION_COUNT → the autopilot asks for each item (MISSION_REQUEST_INT) → MISSION_ITEM_INT
→ … → MISSION_ACK. Every step is retried on timeout, as the protocol expects. ArduPilot keeps
its home position as item 0, so :meth:`MissionClient.upload` prepends it there and progress
reports both the raw sequence number and the index in the caller's list. Progress comes from
MISSION_CURRENT (the item being flown) and MISSION_ITEM_REACHED; it is the autopilot that flies, so
a mission keeps going when this link (or the whole companion computer) is gone, and a new
:class:`MissionClient` picks the progress up again after reconnecting.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass

from dronefleet.drone.fc.mavlink.commands import CommandSender
from dronefleet.drone.fc.mavlink.link import LinkLost, MavlinkLink
from dronefleet.geo.types import LLA
from dronefleet.protocols.mavlink.codec import Message
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.protocols.mavlink.items import (
    ABSOLUTE,
    MISSION,
    MissionItem,
    placed,
    px4_frames,
)
from dronefleet.protocols.mavlink.modes import Autopilot
from dronefleet.vehicle.base import FcError

#: What each transfer is called in a refusal.
_KIND = {
    MISSION: "mission",
    mav.MAV_MISSION_TYPE_FENCE: "geofence",
    mav.MAV_MISSION_TYPE_RALLY: "rally point",
}


@dataclass(frozen=True, slots=True)
class MissionProgress:
    """One progress event: ``kind`` is "current" (now flying ``seq``) or "reached"."""

    kind: str
    seq: int
    index: int  # position in the uploaded list (seq minus ArduPilot's home item)
    total: int | None
    vehicle_time_s: float


class MissionClient:
    """The mission facade of one vehicle (``fc.mission``)."""

    def __init__(
        self,
        link: MavlinkLink,
        commands: CommandSender,
        autopilot: Autopilot,
        clock,
        *,
        timeout_s: float = 1.5,
        retries: int = 5,
    ) -> None:
        self.link = link
        self.commands = commands
        self.autopilot = autopilot
        self.clock = clock
        self.timeout_s = timeout_s
        self.retries = retries
        self.current_seq: int | None = None
        self.reached: list[int] = []
        #: Pictures the autopilot reported, by message type (ArduPilot sends CAMERA_FEEDBACK, a
        #: MAVLink camera CAMERA_IMAGE_CAPTURED, some both): the larger count is the photo count.
        self.photos: dict[str, int] = {"CAMERA_FEEDBACK": 0, "CAMERA_IMAGE_CAPTURED": 0}
        self._queues: list[asyncio.Queue[MissionProgress]] = []
        self._total: int | None = None
        self.uploaded: list[MissionItem] = []  # the mission as sent, seq by seq
        #: Called before MISSION_START: the controller expects AUTO (drone/takeover.py).
        self.on_start: Callable[[], None] | None = None
        #: The vehicle's position now (the controller's), for items flown where it is.
        self.here: Callable[[], LLA | None] | None = None
        link.add_listener(self._on_message)

    @property
    def offset(self) -> int:
        """Items before the caller's first one (ArduPilot's home at seq 0)."""
        return 1 if self.autopilot is Autopilot.ARDUPILOT else 0

    # -- upload / download ------------------------------------------------------------------
    async def upload(
        self, items: list[MissionItem], home: LLA | None = None, mission_type: int = MISSION
    ) -> None:
        """Replace the vehicle's mission (or fence, or rally points: ``mission_type``) with
        ``items``; returns once the autopilot accepted."""
        full = self._as_flown(items, home) if mission_type == MISSION else list(items)
        if self.offset and mission_type == MISSION:
            h = home or LLA(0.0, 0.0, 0.0)
            full.insert(
                0, MissionItem(mav.MAV_CMD_NAV_WAYPOINT, z=h.alt_m, frame=ABSOLUTE).at(h.lat, h.lon)
            )
        target, comp = self._target(), self.link.target_component
        count = mav.MAVLink_mission_count_message(target, comp, len(full), mission_type)
        done: asyncio.Future[Message] = asyncio.get_running_loop().create_future()
        requests: asyncio.Queue[int] = asyncio.Queue()

        def on(msg: Message) -> None:
            kind = msg.get_type()
            if getattr(msg, "mission_type", MISSION) != mission_type or not self._for_us(msg):
                return
            if kind in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
                requests.put_nowait(msg.seq)
            elif kind == "MISSION_ACK" and not done.done():
                done.set_result(msg)

        remove = self.link.add_listener(on)
        try:
            self._send(count)
            misses = 0
            while not done.done():
                getter = asyncio.ensure_future(requests.get())
                finished, _ = await asyncio.wait(
                    {getter, done}, timeout=self.timeout_s, return_when=asyncio.FIRST_COMPLETED
                )
                if getter in finished:
                    seq = getter.result()
                    if 0 <= seq < len(full):
                        self._send(full[seq].to_message(target, comp, seq, mission_type))
                    misses = 0
                    continue
                getter.cancel()
                if done.done():
                    break
                misses += 1
                if misses > self.retries:
                    raise FcError(
                        f"mission upload: the autopilot stopped answering ({self.link.describe()})"
                    )
                self._send(count)  # nothing asked yet (or lost): start over
            ack = done.result()
        finally:
            remove()
        if ack.type != mav.MAV_MISSION_ACCEPTED:
            entry = mav.enums["MAV_MISSION_RESULT"].get(ack.type)
            reason = entry.name if entry else str(ack.type)
            raise FcError(f"{_KIND.get(mission_type, 'mission')} upload refused: {reason}")
        if mission_type == MISSION:
            self._total = len(full)
            self.uploaded = full

    def _as_flown(self, items: list[MissionItem], home: LLA | None) -> list[MissionItem]:
        """The mission's items with the take-off and land placed where the vehicle is
        (items.placed) and, for PX4, position-less items in MAV_FRAME_MISSION."""
        here = (self.here() if self.here is not None else None) or home
        full = list(items) if here is None else placed(list(items), here.lat, here.lon)
        return px4_frames(full) if self.autopilot is Autopilot.PX4 else full

    def flying_to_rtl(self) -> bool:
        """Whether the mission flown now goes on to its NAV_RETURN_TO_LAUNCH next: the current
        item is that item, or the last item with a position before it."""
        cur = self.current_seq
        if cur is None or not 0 <= cur < len(self.uploaded):
            return False
        for item in self.uploaded[cur:]:
            if item.command == mav.MAV_CMD_NAV_RETURN_TO_LAUNCH:
                return True
            if item.is_nav and item is not self.uploaded[cur]:
                return False
        return False

    async def download(self, mission_type: int = MISSION) -> list[MissionItem]:
        """The mission (or fence, or rally points) on board, without ArduPilot's home item."""
        target, comp = self._target(), self.link.target_component

        def ours(m: Message) -> bool:
            return getattr(m, "mission_type", MISSION) == mission_type

        count_msg = await self._ask(
            mav.MAVLink_mission_request_list_message(target, comp, mission_type),
            "MISSION_COUNT",
            ours,
        )
        items: list[MissionItem] = []
        for seq in range(count_msg.count):
            item = await self._ask(
                mav.MAVLink_mission_request_int_message(target, comp, seq, mission_type),
                "MISSION_ITEM_INT",
                lambda m, seq=seq: m.seq == seq and ours(m),
            )
            items.append(MissionItem.from_message(item))
        ack = mav.MAVLink_mission_ack_message(target, comp, mav.MAV_MISSION_ACCEPTED, mission_type)
        self._send(ack)
        if mission_type != MISSION:
            return items
        self._total = len(items)
        return items[self.offset :]

    async def clear(self) -> None:
        target, comp = self._target(), self.link.target_component
        ack = await self._ask(
            mav.MAVLink_mission_clear_all_message(target, comp, MISSION), "MISSION_ACK"
        )
        if ack.type != mav.MAV_MISSION_ACCEPTED:
            raise FcError(f"mission clear refused ({ack.type})")

    async def start(self, first_index: int = 0) -> None:
        """Fly the mission on board from ``first_index`` (switches to AUTO; must be armed).

        Copter denies MISSION_START with a first or last item (GCS_MAVLink_Copter.cpp): the
        first item is made current, then the mission starts there with (0, 0)."""
        await self.set_current(first_index)
        if self.on_start is not None:
            self.on_start()
        await self.commands.long(mav.MAV_CMD_MISSION_START, 0, 0)

    async def set_current(self, index: int) -> None:
        """Make item ``index`` current: MAV_CMD_DO_SET_MISSION_CURRENT, or, where the autopilot
        does not support the command (PX4 at b765769f50 answers UNSUPPORTED), the
        MISSION_SET_CURRENT message, which asks the vehicle to "emit MISSION_CURRENT (whether or
        not the mission number changed)" (MAVLink common.xml): that is its answer."""
        seq = index + self.offset
        if self.autopilot is not Autopilot.PX4:
            await self.commands.long(mav.MAV_CMD_DO_SET_MISSION_CURRENT, seq)
            return
        try:
            await self.commands.long(mav.MAV_CMD_DO_SET_MISSION_CURRENT, seq)
            return
        except FcError as exc:
            if "UNSUPPORTED" not in str(exc).upper():
                raise
        message = mav.MAVLink_mission_set_current_message(
            self._target(), self.link.target_component, seq
        )
        await self._ask(message, "MISSION_CURRENT", lambda m: m.seq == seq)

    # -- progress -------------------------------------------------------------------------------
    @property
    def photo_count(self) -> int:
        return max(self.photos.values())

    def _on_message(self, msg: Message) -> None:
        kind = msg.get_type()
        if kind in self.photos:
            self.photos[kind] += 1
        elif kind == "MISSION_CURRENT":
            total = getattr(msg, "total", 0) or self._total
            if msg.seq == self.current_seq:
                return
            self.current_seq = msg.seq
            self._publish(
                MissionProgress("current", msg.seq, msg.seq - self.offset, total, self.clock.now())
            )
        elif kind == "MISSION_ITEM_REACHED":
            self.reached.append(msg.seq)
            self._publish(
                MissionProgress(
                    "reached", msg.seq, msg.seq - self.offset, self._total, self.clock.now()
                )
            )

    def _publish(self, event: MissionProgress) -> None:
        for queue in self._queues:
            queue.put_nowait(event)

    async def progress(self) -> AsyncIterator[MissionProgress]:
        """Progress events as the autopilot reports them (async generator; runs until closed).
        Starts with the item being flown now, when known."""
        queue: asyncio.Queue[MissionProgress] = asyncio.Queue()
        if self.current_seq is not None:
            seq = self.current_seq
            queue.put_nowait(
                MissionProgress("current", seq, seq - self.offset, self._total, self.clock.now())
            )
        self._queues.append(queue)
        try:
            while True:
                yield await queue.get()
        finally:
            with contextlib.suppress(ValueError):
                self._queues.remove(queue)

    # -- internals -------------------------------------------------------------------------------
    def _target(self) -> int:
        if self.link.target_system is None:
            raise FcError(self.link.describe())
        return self.link.target_system

    def _for_us(self, msg: Message) -> bool:
        """Whether a transfer message is addressed to this station (0: to everyone). The
        autopilot talks to every station on the same link: another station's upload asks for its
        items with MISSION_REQUESTs addressed to that station, which must not be answered here
        with ours (issue 10)."""
        system = getattr(msg, "target_system", 0)
        component = getattr(msg, "target_component", 0)
        return system in (0, self.link.source_system) and component in (
            0,
            self.link.source_component,
        )

    def _send(self, msg: Message) -> None:
        try:
            self.link.send(msg)
        except LinkLost as exc:
            raise FcError(str(exc)) from exc

    async def _ask(self, request: Message, answer: str, predicate=None) -> Message:
        for _ in range(self.retries + 1):
            self._send(request)
            got = await self.link.wait_for(
                answer, lambda m: self._for_us(m) and (predicate is None or predicate(m)),
                self.timeout_s,
            )  # fmt: skip
            if got is not None:
                return got
        raise FcError(f"no {answer} from the autopilot ({self.link.describe()})")
