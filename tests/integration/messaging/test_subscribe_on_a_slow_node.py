"""A SUBSCRIBE on a broker node that answers late, refuses, or dies before answering
(messaging/mqtt_link.py, messaging/client.py).

A NATS node that takes a persistent session over restores its QoS 1 subscriptions before it reads
the next packet, 5 s for each whose JetStream consumer has no leader; then it refuses (SUBACK
0x80) a filter whose consumer it still cannot make. A drone gave up on such a link after aiomqtt's
10 s and began again on the next node, and a refused filter was taken for subscribed. The node
here is a scripted MQTT 3.1.1 server on loopback: it answers the CONNECT, then each SUBSCRIBE as
the test says.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import AsyncIterator, Callable

import aiomqtt
import pytest

from dronefleet.messaging import client as client_module
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.mqtt_link import SUBACK_REFUSED, subscribed
from support.ground_fakes import eventually

pytestmark = pytest.mark.integration

CONNACK = bytes([0x20, 0x02, 0x00, 0x00])

#: How the node answers its n-th SUBSCRIBE (from 0): (seconds to wait, a code per filter, or
#: None to close the link instead).
Answer = Callable[[int, int], tuple[float, list[int] | None]]


async def read_packet(reader: asyncio.StreamReader) -> tuple[int, bytes]:
    kind = (await reader.readexactly(1))[0]
    length, shift = 0, 0
    while True:
        byte = (await reader.readexactly(1))[0]
        length += (byte & 0x7F) << shift
        shift += 7
        if not byte & 0x80:
            break
    return kind, await reader.readexactly(length)


def filters_in(body: bytes) -> list[tuple[str, int]]:
    """The filters (and QoS asked) a SUBSCRIBE's body (after its packet id) holds."""
    found, at = [], 2
    while at < len(body):
        size = int.from_bytes(body[at : at + 2], "big")
        found.append((body[at + 2 : at + 2 + size].decode(), body[at + 2 + size]))
        at += 2 + size + 1
    return found


class ScriptedNode:
    def __init__(self, answer: Answer) -> None:
        self.answer = answer
        self.subscribes = 0
        self.asked: list[tuple[str, int]] = []  # every filter of every SUBSCRIBE, with its QoS
        self.port = 0

    async def serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        with contextlib.suppress(asyncio.IncompleteReadError, ConnectionError):
            await read_packet(reader)  # CONNECT
            writer.write(CONNACK)
            while True:
                kind, body = await read_packet(reader)
                if kind == 0xC0:  # PINGREQ
                    writer.write(bytes([0xD0, 0x00]))
                if kind != 0x82:
                    continue
                filters = filters_in(body)
                self.asked += filters
                wait_s, codes = self.answer(self.subscribes, len(filters))
                self.subscribes += 1
                await asyncio.sleep(wait_s)
                if codes is None:
                    break
                writer.write(bytes([0x90, 2 + len(codes)]) + body[:2] + bytes(codes))
        writer.close()


@contextlib.asynccontextmanager
async def scripted_node(answer: Answer) -> AsyncIterator[ScriptedNode]:
    node = ScriptedNode(answer)
    server = await asyncio.start_server(node.serve, "127.0.0.1", 0)
    node.port = server.sockets[0].getsockname()[1]
    try:
        yield node
    finally:
        server.close()


async def test_a_suback_later_than_aiomqtts_timeout_is_waited_for():
    async with scripted_node(lambda n, filters: (2.0, [1] * filters)) as node:
        async with aiomqtt.Client("127.0.0.1", node.port, timeout=1.0) as client:
            started = time.monotonic()
            assert await subscribed(client, [("D1/mission/in", 1), ("D1/gear/in", 1)]) == [
                True,
                True,
            ]
            assert time.monotonic() - started >= 2.0  # past the client's own 1 s


async def test_a_subscribe_ends_when_its_link_is_lost_not_at_its_timeout():
    async with scripted_node(lambda n, filters: (0.5, None)) as node:
        async with contextlib.AsyncExitStack() as stack:
            client = await stack.enter_async_context(aiomqtt.Client("127.0.0.1", node.port))
            with pytest.raises(aiomqtt.MqttError, match="lost"):
                async with asyncio.timeout(20):  # SUBACK_WAIT_S is 60
                    await subscribed(client, [("D1/mission/in", 1)])
            stack.pop_all()  # the link is gone: nothing to disconnect


async def test_a_refused_filter_is_asked_again_until_the_broker_takes_it(monkeypatch):
    monkeypatch.setattr(client_module, "REFUSED_AGAIN_S", 0.05)
    answers = [SUBACK_REFUSED, SUBACK_REFUSED, 1]
    async with scripted_node(lambda n, filters: (0.0, [answers[min(n, 2)]] * filters)) as node:
        client = BrokerClient(f"mqtt://127.0.0.1:{node.port}", "planner", persistent_session=True)
        await client.subscribe("D1/mission/in", lambda *_: asyncio.sleep(0))
        try:
            await client.start(timeout_s=10)  # linked at once: the filter is asked again behind
            await eventually(lambda: client._at_broker == {"D1/mission/in": 1})
            assert node.subscribes == 3
        finally:
            await client.stop()


async def test_a_filter_refused_every_time_is_left_unsubscribed_and_said(monkeypatch, caplog):
    monkeypatch.setattr(client_module, "REFUSED_AGAIN_S", 0.05)
    async with scripted_node(lambda n, filters: (0.0, [SUBACK_REFUSED] * filters)) as node:
        client = BrokerClient(f"mqtt://127.0.0.1:{node.port}", "planner", persistent_session=True)
        await client.subscribe("D1/mission/in", lambda *_: asyncio.sleep(0))
        try:
            with caplog.at_level(logging.WARNING, "dronefleet.messaging.client"):
                await client.start(timeout_s=10)
                assert client.connected  # the link works on without the filter
                await eventually(lambda: "refused ['D1/mission/in'] 10 times" in caplog.text)
            await asyncio.sleep(0.5)  # no round after the last
            assert node.subscribes == client_module.REFUSED_TRIES
            assert client._at_broker == {}
        finally:
            await client.stop()


async def test_a_clean_session_holds_its_filters_at_qos_0_and_a_persistent_one_as_asked():
    """A clean session's messages end with its link: QoS 1 would deliver nothing more, and on
    NATS it made a JetStream consumer per filter that a reconnect had to wait for."""
    async with scripted_node(lambda n, filters: (0.0, [0] * filters)) as node:
        url = f"mqtt://127.0.0.1:{node.port}"
        for persistent in (False, True):
            client = BrokerClient(url, "D1-drone", persistent_session=persistent)
            await client.subscribe("D1/mission/in", lambda *_: asyncio.sleep(0), qos=1)
            await client.subscribe("D1/telemetry/in", lambda *_: asyncio.sleep(0), qos=0)
            try:
                await client.start(timeout_s=10)
            finally:
                await client.stop()
    clean, persistent = node.asked[:2], node.asked[2:]
    assert sorted(clean) == [("D1/mission/in", 0), ("D1/telemetry/in", 0)]
    assert sorted(persistent) == [("D1/mission/in", 1), ("D1/telemetry/in", 0)]
