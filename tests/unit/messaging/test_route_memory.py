"""The bus and each client remember who a topic goes to (issue 27, item 5): a filter added or
dropped after traffic on a topic changes where its next message goes."""

from __future__ import annotations

import asyncio

from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.local_bus import LocalBus


async def _settle() -> None:
    for _ in range(5):
        await asyncio.sleep(0)


async def test_a_subscriber_added_after_traffic_gets_the_next_message():
    got: dict[str, list[str]] = {"exact": [], "wild": [], "late": []}

    def keep(name: str):
        async def handler(topic: str, payload: bytes) -> None:
            got[name].append(payload.decode())

        return handler

    async with LocalBus(anonymous=True) as bus:
        async with (
            BrokerClient(bus.url, "a") as a,
            BrokerClient(bus.url, "b") as b,
            BrokerClient(bus.url, "pub") as pub,
        ):
            await a.subscribe("QUAD_1/telemetry/out", keep("exact"), qos=0)
            await pub.publish("QUAD_1/telemetry/out", b"1", qos=0)
            await _settle()
            await b.subscribe("+/telemetry/out", keep("wild"), qos=0)  # a wildcard, later
            await pub.publish("QUAD_1/telemetry/out", b"2", qos=0)
            await _settle()
            await a.subscribe("QUAD_1/#", keep("late"), qos=0)  # a second filter of the client
            await pub.publish("QUAD_1/telemetry/out", b"3", qos=0)
            await _settle()
        await b.stop()
        async with BrokerClient(bus.url, "pub2") as pub2:
            await pub2.publish("QUAD_1/telemetry/out", b"4", qos=0)  # b is gone, a too
            await _settle()
    assert got == {"exact": ["1", "2", "3"], "wild": ["2", "3"], "late": ["3"]}


async def test_an_unsubscribed_filter_gets_nothing_more():
    got: list[str] = []
    async with LocalBus(anonymous=True) as bus:
        link = bus.connect(
            "a", None, None, clean=True, deliver=lambda t, p, m, q: got.append(p.decode())
        )
        for pattern in ("QUAD_1/telemetry/out", "+/telemetry/out"):
            await link.subscribe(pattern, 0)
            bus.route(None, "QUAD_1/telemetry/out", b"in", 0, False)
            await link.unsubscribe(pattern)
            bus.route(None, "QUAD_1/telemetry/out", b"out", 0, False)
        link.disconnect()
    assert got == ["in", "in"]
