"""A persistent session's QoS 1 message that NATS sends again while the first copy still waits for
its handler (its ``ack_wait``, 2 s, ran out: a loaded host, a backlog after a takeover) is not
queued twice (messaging/client.py). Queued, every copy of a backlog over 2 s came again every
2 s, the full queue dropped the oldest, acknowledging originals no copy was left of, and a
mission's progress reports were lost (CI: test_mission_on_a_cluster at a load of 15)."""

from __future__ import annotations

import asyncio

from dronefleet.messaging.client import BrokerClient


class Link:
    """paho's side of one connection: what was acknowledged."""

    def __init__(self) -> None:
        self.acked: list[int] = []

    def ack(self, mid: int, qos: int) -> None:
        self.acked.append(mid)


async def test_a_copy_of_a_waiting_message_is_not_queued_again_and_a_later_one_is() -> None:
    release = asyncio.Event()
    handled: list[bytes] = []

    async def slow(topic: str, payload: bytes) -> None:
        await release.wait()
        handled.append(payload)

    client = BrokerClient("mqtt://127.0.0.1:1", "ground-planner", persistent_session=True)
    await client.subscribe("+/mission/out", slow, qos=1)
    link = Link()
    client._dispatch("Q1/mission/out", b"report 1", mid=7, qos=1, link=link)
    client._dispatch("Q1/mission/out", b"report 2", mid=8, qos=1, link=link)
    for _ in range(5):  # NATS's ack_wait ran out five times: five copies of each
        client._dispatch("Q1/mission/out", b"report 1", mid=7, qos=1, link=link)
        client._dispatch("Q1/mission/out", b"report 2", mid=8, qos=1, link=link)
    assert client.redelivered == 10
    release.set()
    for _ in range(20):
        await asyncio.sleep(0)
    assert handled == [b"report 1", b"report 2"] and link.acked == [7, 8]
    # Acknowledged, the packet id is free: the broker's next message with it is a new one.
    client._dispatch("Q1/mission/out", b"report 3", mid=7, qos=1, link=link)
    for _ in range(20):
        await asyncio.sleep(0)
    assert handled[-1] == b"report 3" and link.acked == [7, 8, 7]
    # The same id on another link (a reconnect) is the session's redelivery: queued.
    other = Link()
    client._dispatch("Q1/mission/out", b"report 3", mid=7, qos=1, link=other)
    for _ in range(20):
        await asyncio.sleep(0)
    assert len(handled) == 4 and other.acked == [7]
    await client.stop()
