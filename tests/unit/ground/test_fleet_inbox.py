"""The Fleet Inbox (ground/inbox.py): each drone message read once, handed to every ground
service in process. No broker: messages are handed in as the broker client hands them
(``FleetInbox.receive``)."""

from __future__ import annotations

import asyncio
import re

import orjson
import pytest

from dronefleet.ground.inbox import FleetInbox
from dronefleet.ground.telemetry.store import FIELD_RE
from dronefleet.messaging import telemetry_schema
from dronefleet.messaging.status import Heartbeat, Telemetry
from support.heartbeats import heartbeat


def telemetry(drone_id: str, **extra: object) -> bytes:
    message = {"drone_id": drone_id, "vehicle_time_s": 12.5, "fields": {"lat": 40.6, "lon": -8.6}}
    return orjson.dumps({**message, **extra})


@pytest.fixture
def inbox() -> FleetInbox:
    return FleetInbox("mqtt://127.0.0.1:1", client_id="test-inbox")  # never connected


async def test_a_message_is_read_once_and_every_consumer_is_handed_the_same_model(inbox) -> None:
    direct: list[Telemetry] = []
    queued: list[Telemetry] = []

    async def slow_enough(message: Telemetry) -> None:
        queued.append(message)

    inbox.telemetry.direct("store", direct.append)
    inbox.telemetry.queued("monitor", slow_enough)
    # A newer drone's extra field is ignored, not refused (messaging/inbound.py).
    inbox.receive(inbox.telemetry, "QUAD_1/telemetry/out", telemetry("QUAD_1", newer=1))
    assert len(direct) == 1 and isinstance(direct[0], Telemetry)
    assert direct[0].fields == {"lat": 40.6, "lon": -8.6}
    await asyncio.sleep(0)
    assert queued == direct and queued[0] is direct[0]
    await inbox.stop()


async def test_malformed_and_forged_messages_are_dropped_and_counted_once_by_why(inbox) -> None:
    handed: list[object] = []
    inbox.telemetry.direct("a", handed.append)
    inbox.telemetry.direct("b", handed.append)
    inbox.heartbeats.direct("a", handed.append)
    inbox.receive(inbox.telemetry, "QUAD_1/telemetry/out", b"\xff not json")
    inbox.receive(inbox.telemetry, "QUAD_2/telemetry/out", telemetry("QUAD_1"))
    inbox.receive(inbox.heartbeats, "QUAD_1/heartbeats/out", b'{"drone_id": "QUAD_1"}')
    inbox.receive(inbox.heartbeats, "QUAD_2/heartbeats/out", heartbeat("QUAD_1", 3.0))
    inbox.receive(inbox.heartbeats, "QUAD_1/heartbeats/out", heartbeat("QUAD_1", 3.0))
    assert inbox.dropped_counts() == {
        "malformed telemetry": 1,
        "telemetry on another drone's topic": 1,
        "malformed heartbeat": 1,
        "heartbeat on another drone's topic": 1,
    }
    assert len(handed) == 1 and isinstance(handed[0], Heartbeat)


async def test_a_slow_consumer_holds_up_no_other_and_its_full_queue_drops_its_oldest(
    inbox,
) -> None:
    release = asyncio.Event()
    slow: list[float] = []
    quick: list[float] = []
    direct: list[float] = []

    async def stuck(message: Telemetry) -> None:
        await release.wait()
        slow.append(message.vehicle_time_s)

    async def keeping_up(message: Telemetry) -> None:
        quick.append(message.vehicle_time_s)

    inbox.telemetry.queued("separation monitor", stuck, limit=3)
    inbox.telemetry.queued("other", keeping_up)
    inbox.telemetry.direct("store", lambda m: direct.append(m.vehicle_time_s))
    for n in range(10):
        inbox.receive(
            inbox.telemetry, "QUAD_1/telemetry/out", telemetry("QUAD_1", vehicle_time_s=n)
        )
        await asyncio.sleep(0)
    assert direct == quick == [float(n) for n in range(10)]
    assert inbox.dropped_counts() == {"telemetry queue full (separation monitor)": 6}
    release.set()
    for _ in range(5):
        await asyncio.sleep(0)
    assert slow == [0.0, 7.0, 8.0, 9.0]  # the one it held, then the newest three
    await inbox.stop()


async def test_a_consumer_that_fails_drops_that_message_only(inbox) -> None:
    seen: list[float] = []

    def fussy(message: Telemetry) -> None:
        if message.vehicle_time_s == 1:
            raise ValueError("no")
        seen.append(message.vehicle_time_s)

    inbox.telemetry.direct("fussy", fussy)
    for n in range(3):
        inbox.receive(
            inbox.telemetry, "QUAD_1/telemetry/out", telemetry("QUAD_1", vehicle_time_s=n)
        )
    assert seen == [0.0, 2.0]


async def test_a_detached_consumer_is_handed_nothing_more(inbox) -> None:
    seen: list[Telemetry] = []
    inbox.telemetry.direct("gone", seen.append)
    await inbox.telemetry.detach("gone")
    inbox.receive(inbox.telemetry, "QUAD_1/telemetry/out", telemetry("QUAD_1"))
    assert seen == []


def test_every_field_the_schema_keeps_is_a_name_the_stores_accept() -> None:
    # The connector stores what telemetry_schema.screen keeps without matching FIELD_RE again.
    assert all(FIELD_RE.match(name) for name in telemetry_schema.FLIGHT_FIELDS)
    sensor = telemetry_schema._SENSOR_FIELD.pattern
    assert sensor == r"^([a-z][a-z0-9]{0,31})_([a-z0-9]{1,8})$", "check FIELD_RE still covers it"
    longest = "a" + "9" * 31 + "_" + "z" * 8
    assert re.match(sensor, longest) and FIELD_RE.match(longest)
    assert all(FIELD_RE.match(f"co2_{unit}") for unit in telemetry_schema.SENSOR_UNITS)
