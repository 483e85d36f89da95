"""The backend's mission upload answers only the MISSION_REQUESTs addressed to it (issue 10).

An autopilot shares its link with every ground station: a second station uploading its own mission
gets MISSION_REQUESTs addressed to it, and an upload here that answered them would send our items
into that station's transfer (and count its MISSION_ACK as ours).
"""

from __future__ import annotations

import asyncio

from dronefleet.drone.fc.mavlink.mission import MissionClient
from dronefleet.protocols.mavlink import items as mi
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.protocols.mavlink.modes import Autopilot

US, OTHER, VEHICLE = 255, 250, 1
MISSION = mav.MAV_MISSION_TYPE_MISSION


class Link:
    """What MissionClient uses of a MavlinkLink: listeners, sends, addresses."""

    target_system, target_component = VEHICLE, 1
    source_system, source_component = US, mav.MAV_COMP_ID_MISSIONPLANNER

    def __init__(self) -> None:
        self.sent: list = []
        self.listeners: list = []

    def add_listener(self, listener):
        self.listeners.append(listener)
        return lambda: self.listeners.remove(listener)

    def send(self, message) -> None:
        self.sent.append(message)

    def describe(self) -> str:
        return "test link"

    def feed(self, message) -> None:
        for listener in list(self.listeners):
            listener(message)


def items_sent(link: Link) -> list[int]:
    return [m.seq for m in link.sent if m.get_type() == "MISSION_ITEM_INT"]


async def test_requests_and_acks_for_another_station_are_not_answered() -> None:
    link = Link()
    client = MissionClient(link, None, Autopilot.GENERIC, None, timeout_s=0.5, retries=1)
    mission = [mi.takeoff(10), mi.waypoint(40.63, -8.659, 10)]
    upload = asyncio.create_task(client.upload(mission))
    await asyncio.sleep(0)
    assert [m.get_type() for m in link.sent] == ["MISSION_COUNT"]
    comp = mav.MAV_COMP_ID_MISSIONPLANNER
    link.feed(mav.MAVLink_mission_request_int_message(OTHER, comp, 0, MISSION))
    link.feed(mav.MAVLink_mission_ack_message(OTHER, comp, mav.MAV_MISSION_ACCEPTED, MISSION))
    await asyncio.sleep(0)
    assert items_sent(link) == [] and not upload.done()  # the other station's, not ours
    for seq in (0, 1):
        link.feed(mav.MAVLink_mission_request_int_message(US, comp, seq, MISSION))
        await asyncio.sleep(0.01)  # the item goes out before the next request
    link.feed(mav.MAVLink_mission_ack_message(US, comp, mav.MAV_MISSION_ACCEPTED, MISSION))
    await upload
    assert items_sent(link) == [0, 1]


async def test_a_broadcast_request_is_answered() -> None:
    link = Link()
    client = MissionClient(link, None, Autopilot.GENERIC, None, timeout_s=0.5, retries=1)
    upload = asyncio.create_task(client.upload([mi.takeoff(10)]))
    await asyncio.sleep(0)
    link.feed(mav.MAVLink_mission_request_int_message(0, 0, 0, MISSION))
    link.feed(mav.MAVLink_mission_ack_message(0, 0, mav.MAV_MISSION_ACCEPTED, MISSION))
    await upload
    assert items_sent(link) == [0]
