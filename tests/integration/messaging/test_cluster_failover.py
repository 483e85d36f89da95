"""Broker clients fail over between the nodes of a cluster (issue 27): one URL names the nodes,
``mqtt://127.0.0.1:A,127.0.0.1:B,127.0.0.1:C``, and a client whose node dies goes on to the next
with the same client id and session flag.

On a 3-node NATS cluster (tests/support/nats_cluster.py: MQTT sessions replicated on the three):
a persistent-session subscriber (QoS 1, as the planner's) and a publisher, each on its own node;
the subscriber's node is killed, then (once it is back) the publisher's. Both are linked again
to another node within seconds, and every QoS 1 message the publisher had sent (its PUBACK
received) reaches the subscriber, those sent while it was away included: none lost; a message
may come twice, as QoS 1 allows. And the failure paths: every node down, the client keeps
trying them in turn and is back as soon as one returns; a node that never answers is left for
the next, its socket closed."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import threading
import time
from collections.abc import Callable

import pytest

from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.ports import free_port
from dronefleet.messaging.url import BrokerNode, BrokerUrl
from support.brokers import Mosquitto
from support.nats_cluster import ClusterNode, nats_cluster, wait_sessions

pytestmark = pytest.mark.integration

TOPIC = "failover/test"


def cluster_url(nodes: list[ClusterNode]) -> BrokerUrl:
    """The cluster's URL, its nodes in this order (the first is tried first)."""
    return BrokerUrl.parse("mqtt://" + ",".join(f"127.0.0.1:{n.mqtt_port}" for n in nodes))


async def linked_again(client: BrokerClient, lost: BrokerNode, deadline_s: float) -> float:
    """Seconds until ``client`` is linked to a node other than ``lost``."""
    start = time.monotonic()
    async with asyncio.timeout(deadline_s):
        while client.node is None or client.node == lost:
            await asyncio.sleep(0.01)
    return time.monotonic() - start


class Publisher:
    """A BrokerClient publishing 0, 1, 2... at QoS 1 in a thread of its own, with its own event
    loop, so that it goes on while the test holds the subscriber's loop. ``sent``: each number
    the broker took (PUBACK), with when."""

    def __init__(self, url: BrokerUrl) -> None:
        self.url = url
        self.client: BrokerClient | None = None
        self.sent: list[tuple[int, float]] = []
        self.stalls: list[float] = []  # the publishes that took over 0.5 s, how long
        self._ready = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=lambda: asyncio.run(self._main()), daemon=True)

    def start(self) -> BrokerClient:
        self._thread.start()
        assert self._ready.wait(40), "the publisher never linked"
        assert self.client is not None
        return self.client

    async def _main(self) -> None:
        self.client = client = await BrokerClient(self.url, "failover-pub").start(timeout_s=30)
        self._ready.set()
        n = 0
        while not self._stop.is_set():
            began = time.monotonic()
            await client.publish(TOPIC, str(n).encode(), qos=1)
            self.sent.append((n, time.monotonic()))
            if time.monotonic() - began > 0.5:
                self.stalls.append(time.monotonic() - began)
            n += 1
            await asyncio.sleep(0.005)
        await client.stop()

    def sent_between(self, start: float, end: float) -> list[int]:
        return [n for n, at in self.sent if start <= at <= end]

    async def stop(self) -> None:
        self._stop.set()
        await asyncio.to_thread(self._thread.join, 30)


def hold_until(got: Callable[[], list[int]], count: int, deadline_s: float) -> list[int]:
    """Block this thread, and with it the event loop of the test and its clients, until
    ``got()`` has ``count`` items (the publisher's thread goes on); what it had then."""
    until = time.monotonic() + deadline_s
    while len(items := got()) < count:
        assert time.monotonic() < until, f"only {len(items)} published in {deadline_s} s"
        time.sleep(0.01)
    return items


@pytest.fixture
def cluster():
    with nats_cluster(3) as nodes:
        yield nodes


async def restart(node: ClusterNode) -> None:
    node.start()
    await asyncio.to_thread(wait_sessions, node, time.monotonic() + 60)


async def test_a_publisher_and_a_persistent_subscriber_outlive_the_loss_of_their_nodes(cluster):
    n0, n1, n2 = cluster
    by_port = {n.mqtt_port: n for n in cluster}
    received: list[int] = []

    async def collect(_topic: str, payload: bytes) -> None:
        received.append(int(payload))

    subscriber = BrokerClient(cluster_url([n0, n1, n2]), "failover-sub", persistent_session=True)
    sub_id = subscriber.client_id
    await subscriber.start(timeout_s=30)
    await subscriber.subscribe(TOPIC, collect, qos=1)
    pub = Publisher(cluster_url([n1, n2, n0]))
    publisher = await asyncio.to_thread(pub.start)
    try:
        async with asyncio.timeout(10):
            while len(received) < 50:
                await asyncio.sleep(0.02)

        # The subscriber's node dies, and the subscriber is held (its event loop blocked) until
        # the publisher, on another node, has had 20 messages taken: queued for the session.
        assert subscriber.node is not None and publisher.node is not None
        assert subscriber.node != publisher.node
        lost = subscriber.node
        by_port[lost.port].kill()
        killed = time.monotonic()
        away = hold_until(lambda: pub.sent_between(killed, time.monotonic()), 20, 30)
        sub_took = await linked_again(subscriber, lost, 15)
        print(f"subscriber on {subscriber.node} {sub_took:.3f} s after it could try again")
        assert subscriber.client_id == sub_id  # the same session, on another node
        await restart(by_port[lost.port])

        # Then the publisher's node (the subscriber may be on it too now).
        lost = publisher.node
        assert lost is not None
        by_port[lost.port].kill()
        killed = time.monotonic()
        pub_took = await linked_again(publisher, lost, 15)
        print(f"publisher on {publisher.node} {pub_took:.3f} s after {lost} was killed")
        async with asyncio.timeout(15):  # publishing again, through the new node
            while len(pub.sent_between(killed, time.monotonic())) < 50:
                await asyncio.sleep(0.02)
        first_after = pub.sent_between(killed, time.monotonic())[0]
        print(f"publishing again {pub.sent[first_after][1] - killed:.3f} s after the kill")
        async with asyncio.timeout(15):
            while subscriber.node is None:
                await asyncio.sleep(0.02)
    finally:
        await pub.stop()

    sent = {n for n, _ in pub.sent}
    with contextlib.suppress(TimeoutError):
        async with asyncio.timeout(20):
            while not sent <= set(received):
                await asyncio.sleep(0.05)
    lost_messages = sorted(sent - set(received))
    duplicates = len(received) - len(set(received))
    print(
        f"{len(sent)} sent ({len(away)} while the subscriber had no link), "
        f"{len(received)} received: {len(lost_messages)} lost, {duplicates} duplicates; "
        f"subscriber links {subscriber.connections}, publisher links {publisher.connections}; "
        f"publishes stalled: {[round(s, 2) for s in pub.stalls]}"
    )
    await subscriber.stop()
    assert away, "nothing was published while the subscriber was away"
    assert not lost_messages, f"QoS 1 messages lost: {lost_messages[:20]}"
    assert set(received) <= sent | {len(sent)}  # nothing made up (the last may be in flight)
    assert subscriber.connections >= 2 and publisher.connections >= 2


async def test_with_every_node_down_a_client_keeps_trying_them_and_returns_with_one(
    tmp_path, caplog
):
    ports = [free_port() for _ in range(3)]
    url = BrokerUrl.parse("mqtt://" + ",".join(f"127.0.0.1:{p}" for p in ports))
    client = BrokerClient(url, "failover-waits", reconnect_s=0.2)
    caplog.set_level(logging.INFO, logger="dronefleet.messaging.connection")
    await client.start(timeout_s=None)
    try:
        async with asyncio.timeout(10):  # each node tried, in turn, more than once
            while not all(
                sum(f"node 127.0.0.1:{p}: no link" in r.getMessage() for r in caplog.records) >= 2
                for p in ports
            ):
                await asyncio.sleep(0.05)
        assert not client.connected
        broker = Mosquitto(tmp_path, port=ports[2])  # the last node comes back
        broker.start()
        try:
            async with asyncio.timeout(10):
                await client.wait_connected()
            assert client.node == BrokerNode("127.0.0.1", ports[2])
            got: asyncio.Queue[bytes] = asyncio.Queue()

            async def put(_topic: str, payload: bytes) -> None:
                await got.put(payload)

            await client.subscribe("failover/back", put)
            await client.publish("failover/back", b"here", timeout_s=5)
            async with asyncio.timeout(5):
                assert await got.get() == b"here"
        finally:
            await client.stop()
            broker.stop()
    finally:
        await client.stop()


async def test_a_node_that_never_answers_is_left_for_the_next_and_its_socket_closed(tmp_path):
    """A node that takes the TCP link but sends no CONNACK (a hung broker, a NATS node waiting
    on JetStream): the client goes on to the next node, and closes the link it gave up, so that
    no late CONNACK makes a second link with its client id."""
    opened, closed = asyncio.Event(), asyncio.Event()

    async def silent(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        opened.set()
        while await reader.read(4096):  # the CONNECT, then nothing more until the client closes
            pass
        closed.set()
        writer.close()

    server = await asyncio.start_server(silent, "127.0.0.1", 0)
    silent_port = server.sockets[0].getsockname()[1]
    broker = Mosquitto(tmp_path)
    broker.start()
    url = BrokerUrl.parse(f"mqtt://127.0.0.1:{silent_port},127.0.0.1:{broker.port}")
    client = BrokerClient(url, "failover-silent")
    try:
        await client.start(timeout_s=30)
        assert client.node == BrokerNode("127.0.0.1", broker.port)
        assert opened.is_set()
        async with asyncio.timeout(10):
            await closed.wait()
    finally:
        await client.stop()
        broker.stop()
        server.close()
