"""The mission protocol, autopilot side: ground stations upload and download the mission here.

Upload: MISSION_COUNT starts a transfer; the vehicle asks for each item in turn
(MISSION_REQUEST_INT), re-asks when an item does not come within a second, and answers the last
one with MISSION_ACK — only then does the new mission replace the old one, so a broken upload
never leaves half a mission on board. Download: MISSION_REQUEST_LIST → MISSION_COUNT, then one
MISSION_ITEM_INT per request; item 0 reads back as the home position, as ArduPilot keeps it
(issue 10, item 6). MISSION_WRITE_PARTIAL_LIST replaces items ``start_index..end_index`` of the
mission on board the same way (asked for in turn, in force at the last). Also MISSION_CLEAR_ALL
and MISSION_SET_CURRENT.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from dronefleet.clock import monotonic
from dronefleet.protocols.mavlink.codec import Message
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.protocols.mavlink.items import MISSION, MissionItem
from dronefleet.protocols.mavlink.modes import CopterMode

if TYPE_CHECKING:
    from dronefleet.sim.mavlink.copter import SimCopter

_RETRY_WALL_S = 1.0
_MAX_RETRIES = 5
_MAX_ITEMS = 700


class MissionTransfer:
    """Serves the mission protocol for one vehicle; ``send`` goes to the ground."""

    def __init__(self, copter: SimCopter, send: Callable[[Message], None]) -> None:
        self.copter = copter
        self.send = send
        self._incoming: list[MissionItem] | None = None
        self._expected = 0
        self._count = 0
        self._peer: tuple[int, int] = (0, 0)
        self._asked_at = 0.0
        self._retries = 0
        self._first = 0  # the first item an upload replaces (> 0 for a partial write)

    def handle(self, msg: Message) -> bool:
        """Serve ``msg`` if it belongs to the mission protocol; True when it did."""
        kind = msg.get_type()
        if getattr(msg, "mission_type", MISSION) != MISSION and kind.startswith("MISSION"):
            self._ack(msg, mav.MAV_MISSION_UNSUPPORTED, getattr(msg, "mission_type", 0))
            return True
        handler = {
            "MISSION_COUNT": self._on_count,
            "MISSION_WRITE_PARTIAL_LIST": self._on_partial,
            "MISSION_ITEM_INT": self._on_item,
            "MISSION_ITEM": self._on_item,
            "MISSION_REQUEST_LIST": self._on_request_list,
            "MISSION_REQUEST_INT": self._on_request,
            "MISSION_REQUEST": self._on_request,
            "MISSION_CLEAR_ALL": self._on_clear,
            "MISSION_SET_CURRENT": self._on_set_current,
            "MISSION_ACK": lambda m: None,  # end of a download: nothing to do
        }.get(kind)
        if handler is None:
            return False
        handler(msg)
        return True

    # -- upload ---------------------------------------------------------------------------------
    def _on_count(self, msg: Message) -> None:
        if msg.count > _MAX_ITEMS:
            self._ack(msg, mav.MAV_MISSION_NO_SPACE)
            return
        self._peer = (msg.get_srcSystem(), msg.get_srcComponent())
        if msg.count == 0:
            self.copter.on_mission_replaced([])
            self._ack(msg, mav.MAV_MISSION_ACCEPTED)
            return
        self._incoming, self._expected, self._retries, self._first = [], 0, 0, 0
        self._count = msg.count
        self._ask(0)

    def _on_partial(self, msg: Message) -> None:
        mission = self.copter.mission
        start, end = msg.start_index, msg.end_index
        if end == -1:
            end = start  # one item, as the protocol allows
        if not 0 <= start <= end < len(mission):
            self._ack(msg, mav.MAV_MISSION_INVALID_SEQUENCE)
            return
        self._peer = (msg.get_srcSystem(), msg.get_srcComponent())
        self._incoming, self._expected, self._retries = [], start, 0
        self._first, self._count = start, end + 1
        self._ask(start)

    def _on_item(self, msg: Message) -> None:
        if self._incoming is None:
            return  # not uploading: stray or duplicate item
        if msg.seq != self._expected:
            if msg.seq < self._expected:
                return  # a duplicate of one we have
            self._ask(self._expected)
            return
        self._incoming.append(MissionItem.from_message(msg))
        self._expected += 1
        self._retries = 0
        if self._expected < self._count:
            self._ask(self._expected)
            return
        items, self._incoming = self._incoming, None
        if self._first:  # a partial write: the rest of the mission stays as it was
            mission = list(self.copter.mission)
            items = [*mission[: self._first], *items, *mission[self._count :]]
        self.copter.on_mission_replaced(items)
        self._ack(msg, mav.MAV_MISSION_ACCEPTED)

    def _ask(self, seq: int) -> None:
        self._asked_at = monotonic()
        system, component = self._peer
        self.send(mav.MAVLink_mission_request_int_message(system, component, seq, MISSION))

    def tick(self) -> None:
        """Re-ask for a late item; give up after a few tries."""
        if self._incoming is None or monotonic() - self._asked_at < _RETRY_WALL_S:
            return
        self._retries += 1
        if self._retries > _MAX_RETRIES:
            self._incoming = None
            system, component = self._peer
            self.send(
                mav.MAVLink_mission_ack_message(
                    system, component, mav.MAV_MISSION_OPERATION_CANCELLED, MISSION
                )
            )
            return
        self._ask(self._expected)

    # -- download and the rest ----------------------------------------------------------------
    def _on_request_list(self, msg: Message) -> None:
        self.send(
            mav.MAVLink_mission_count_message(
                msg.get_srcSystem(), msg.get_srcComponent(), len(self.copter.mission), MISSION
            )
        )

    def _on_request(self, msg: Message) -> None:
        mission = self.copter.mission
        if not 0 <= msg.seq < len(mission):
            self._ack(msg, mav.MAV_MISSION_INVALID_SEQUENCE)
            return
        item = mission[msg.seq] if msg.seq else self._home()
        self.send(item.to_message(msg.get_srcSystem(), msg.get_srcComponent(), msg.seq))

    def _home(self) -> MissionItem:
        """Item 0 as ArduPilot reads it back: the home position (absolute altitude)."""
        home = self.copter.vehicle.home
        return MissionItem(
            mav.MAV_CMD_NAV_WAYPOINT,
            x=round(home.lat * 1e7),
            y=round(home.lon * 1e7),
            z=home.alt_m,
            frame=mav.MAV_FRAME_GLOBAL,
        )

    def _on_clear(self, msg: Message) -> None:
        c = self.copter
        if c.mode is CopterMode.AUTO and c.vehicle.armed:
            # ArduPilot refuses to clear the mission it is flying (issue 10, item 9).
            self._ack(msg, mav.MAV_MISSION_DENIED)
            return
        c.on_mission_replaced([])
        self._ack(msg, mav.MAV_MISSION_ACCEPTED)

    def _on_set_current(self, msg: Message) -> None:
        if 0 <= msg.seq < len(self.copter.mission):
            self.copter.runner.set_current(msg.seq)

    def _ack(self, msg: Message, result: int, mission_type: int = MISSION) -> None:
        self.send(
            mav.MAVLink_mission_ack_message(
                msg.get_srcSystem(), msg.get_srcComponent(), result, mission_type
            )
        )
