"""The mission protocol, autopilot side: ground stations upload and download the mission, the
geofence and the rally points here (MAV_MISSION_TYPE_MISSION, _FENCE, _RALLY), as ArduPilot's
MissionItemProtocol serves them.

Upload: MISSION_COUNT starts a transfer; the vehicle asks for each item in turn
(MISSION_REQUEST_INT), re-asks when an item does not come within a second, and answers the last
one with MISSION_ACK — only then do the new items replace the old ones, so a broken upload never
leaves half a mission on board. MISSION_WRITE_PARTIAL_LIST does the same for items start..end
(inclusive; end may be one past the last item, which appends), keeping the others. Download:
MISSION_REQUEST_LIST → MISSION_COUNT, then one MISSION_ITEM_INT per request. The mission's item 0
is home, as ArduPilot keeps it: it always reads back as the current home position (so even an
empty mission has one item). Also MISSION_CLEAR_ALL (any type, or all) and MISSION_SET_CURRENT.
MIS_TOTAL, FENCE_TOTAL and RALLY_TOTAL follow what is stored, as on ArduPilot (issue 10, item 4).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from dronefleet.clock import monotonic
from dronefleet.protocols.mavlink.codec import Message
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.protocols.mavlink.items import MISSION, MissionItem
from dronefleet.protocols.mavlink.modes import CopterMode

if TYPE_CHECKING:
    from dronefleet.sim.mavlink.copter import SimCopter

FENCE = mav.MAV_MISSION_TYPE_FENCE
RALLY = mav.MAV_MISSION_TYPE_RALLY
_ALL = mav.MAV_MISSION_TYPE_ALL
_TOTALS = {MISSION: "MIS_TOTAL", FENCE: "FENCE_TOTAL", RALLY: "RALLY_TOTAL"}
_RETRY_WALL_S = 1.0
_MAX_RETRIES = 5
_MAX_ITEMS = 700


@dataclass
class _Upload:
    kind: int
    items: list[MissionItem]  # what will be stored: a copy of the old list for a partial write
    expected: int  # next seq asked for
    last: int  # last seq of the transfer (inclusive)
    peer: tuple[int, int]
    asked_at: float = 0.0
    retries: int = 0
    got: set[int] = field(default_factory=set)


class MissionTransfer:
    """Serves the mission protocol for one vehicle; ``send`` goes to the ground."""

    def __init__(self, copter: SimCopter, send: Callable[[Message], None]) -> None:
        self.copter = copter
        self.send = send
        self.stored: dict[int, list[MissionItem]] = {FENCE: [], RALLY: []}
        self._upload: _Upload | None = None

    def handle(self, msg: Message) -> bool:
        """Serve ``msg`` if it belongs to the mission protocol; True when it did."""
        kind = msg.get_type()
        if not kind.startswith("MISSION"):
            return False
        mission_type = getattr(msg, "mission_type", MISSION)
        if mission_type not in _TOTALS and not (
            kind == "MISSION_CLEAR_ALL" and mission_type == _ALL
        ):
            self._ack(msg, mav.MAV_MISSION_UNSUPPORTED, mission_type)
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

    # -- what is stored -------------------------------------------------------------------------
    def items(self, mission_type: int) -> list[MissionItem]:
        """The items a download sends: for the mission, item 0 is home, now."""
        if mission_type != MISSION:
            return list(self.stored[mission_type])
        home = self.copter.vehicle.home
        item0 = MissionItem(
            mav.MAV_CMD_NAV_WAYPOINT, round(home.lat * 1e7), round(home.lon * 1e7), home.alt_m,
            frame=mav.MAV_FRAME_GLOBAL,
        )  # fmt: skip
        return [item0, *self.copter.mission[1:]]

    def _store(self, mission_type: int, items: list[MissionItem]) -> None:
        if mission_type == MISSION:
            self.copter.on_mission_replaced(items)
        else:
            self.stored[mission_type] = items
        self.copter.params.set(_TOTALS[mission_type], len(self.items(mission_type)))

    # -- upload ---------------------------------------------------------------------------------
    def _on_count(self, msg: Message) -> None:
        if msg.count > _MAX_ITEMS:
            self._ack(msg, mav.MAV_MISSION_NO_SPACE, msg.mission_type)
            return
        if msg.count == 0:
            self._upload = None
            self._store(msg.mission_type, [])
            self._ack(msg, mav.MAV_MISSION_ACCEPTED, msg.mission_type)
            return
        self._begin(msg, [], 0, msg.count - 1)

    def _on_partial(self, msg: Message) -> None:
        kind = msg.mission_type
        current = self.items(kind)
        start, end = msg.start_index, msg.end_index
        if end == -1:  # MAVLink: "to the end of the list"
            end = len(current) - 1
        if not 0 <= start <= end <= len(current) or end >= _MAX_ITEMS:
            self._ack(msg, mav.MAV_MISSION_ERROR, kind)  # ArduPilot's answer to a bad range
            return
        self._begin(msg, list(current), start, end)

    def _begin(self, msg: Message, items: list[MissionItem], first: int, last: int) -> None:
        peer = (msg.get_srcSystem(), msg.get_srcComponent())
        self._upload = _Upload(msg.mission_type, items, first, last, peer)
        self._ask()

    def _on_item(self, msg: Message) -> None:
        up = self._upload
        if up is None or getattr(msg, "mission_type", MISSION) != up.kind:
            return  # not uploading: stray or duplicate item
        if msg.seq != up.expected:
            if msg.seq not in up.got:
                self._ask()  # out of order: ask again for the one we want
            return
        item = MissionItem.from_message(msg)
        if msg.seq < len(up.items):
            up.items[msg.seq] = item
        else:
            up.items.append(item)
        up.got.add(msg.seq)
        up.expected += 1
        up.retries = 0
        if up.expected <= up.last:
            self._ask()
            return
        self._upload = None
        self._store(up.kind, up.items)
        self._ack(msg, mav.MAV_MISSION_ACCEPTED, up.kind)

    def _ask(self) -> None:
        up = self._upload
        assert up is not None
        up.asked_at = monotonic()
        system, component = up.peer
        self.send(mav.MAVLink_mission_request_int_message(system, component, up.expected, up.kind))

    def tick(self) -> None:
        """Re-ask for a late item; give up after a few tries."""
        up = self._upload
        if up is None or monotonic() - up.asked_at < _RETRY_WALL_S:
            return
        up.retries += 1
        if up.retries > _MAX_RETRIES:
            self._upload = None
            system, component = up.peer
            self.send(
                mav.MAVLink_mission_ack_message(
                    system, component, mav.MAV_MISSION_OPERATION_CANCELLED, up.kind
                )
            )
            return
        self._ask()

    # -- download and the rest ----------------------------------------------------------------
    def _on_request_list(self, msg: Message) -> None:
        count = len(self.items(msg.mission_type))
        self.send(
            mav.MAVLink_mission_count_message(
                msg.get_srcSystem(), msg.get_srcComponent(), count, msg.mission_type
            )
        )

    def _on_request(self, msg: Message) -> None:
        kind = msg.mission_type
        items = self.items(kind)
        if not 0 <= msg.seq < len(items):
            self._ack(msg, mav.MAV_MISSION_INVALID_SEQUENCE, kind)
            return
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        self.send(items[msg.seq].to_message(*src, msg.seq, kind))

    def _on_clear(self, msg: Message) -> None:
        c = self.copter
        kind = msg.mission_type
        if kind in (MISSION, _ALL) and c.mode is CopterMode.AUTO and c.vehicle.armed:
            # ArduPilot refuses to clear the mission it is flying (issue 10, item 9).
            self._ack(msg, mav.MAV_MISSION_DENIED, kind)
            return
        for each in (MISSION, FENCE, RALLY) if kind == _ALL else (kind,):
            self._store(each, [])
        self._ack(msg, mav.MAV_MISSION_ACCEPTED, kind)

    def _on_set_current(self, msg: Message) -> None:
        if 0 <= msg.seq < len(self.copter.mission):
            self.copter.runner.set_current(msg.seq)

    def _ack(self, msg: Message, result: int, mission_type: int = MISSION) -> None:
        self.send(
            mav.MAVLink_mission_ack_message(
                msg.get_srcSystem(), msg.get_srcComponent(), result, mission_type
            )
        )
