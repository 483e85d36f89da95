"""The broker client heals itself: reconnects and re-subscribes; requests time out clearly."""

from __future__ import annotations

import asyncio

import pytest

from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.embedded import free_port
from dronefleet.messaging.rpc import Requester, RequestTimeout
from support.brokers import mosquitto

pytestmark = pytest.mark.integration


async def test_publish_and_subscribe_on_both_brokers(broker_url):
    got: asyncio.Queue = asyncio.Queue()
    async with BrokerClient(broker_url, "sub") as sub, BrokerClient(broker_url, "pub") as pub:
        await sub.subscribe("+/control/in", lambda t, p: got.put((t, p)))
        await asyncio.sleep(0.1)
        await pub.publish("Q/control/in", {"command": "arm"})
        assert await asyncio.wait_for(got.get(), 5) == ("Q/control/in", b'{"command":"arm"}')


async def test_a_failing_handler_does_not_stop_the_subscription(embedded_broker):
    got: asyncio.Queue = asyncio.Queue()

    async def handler(topic_name, payload):
        if payload == b"1":
            raise ValueError("boom")
        await got.put(payload)

    async with (
        BrokerClient(embedded_broker, "sub") as sub,
        BrokerClient(embedded_broker, "pub") as pub,
    ):
        await sub.subscribe("t", handler)
        await pub.publish("t", b"1")
        await pub.publish("t", b"2")
        assert await asyncio.wait_for(got.get(), 5) == b"2"


async def test_client_reconnects_and_resubscribes_after_the_broker_restarts(tmp_path):
    port = free_port()
    got: asyncio.Queue = asyncio.Queue()
    with mosquitto(tmp_path, port=port) as url:
        sub = await BrokerClient(url, "sub", reconnect_s=0.2).start()
        await sub.subscribe("a/b", lambda t, p: got.put(p))
    # The broker is gone: a message published now waits for it instead of being lost.
    pub = BrokerClient(url, "pub", reconnect_s=0.2)
    pending = asyncio.create_task(pub.start(timeout_s=None))
    with mosquitto(tmp_path, port=port):
        for _ in range(100):  # the old link's loss may be noticed only now
            if sub.connections == 2 and sub.connected:
                break
            await asyncio.sleep(0.1)
        await pending
        await pub.wait_connected(10)
        await asyncio.sleep(0.2)
        assert await pub.publish("a/b", b"after restart", timeout_s=5)
        assert await asyncio.wait_for(got.get(), 5) == b"after restart"
        assert sub.connections == 2
        await pub.stop()
        await sub.stop()


async def test_request_without_answer_times_out_clearly(embedded_broker):
    async with BrokerClient(embedded_broker, "asker") as client:
        with pytest.raises(RequestTimeout, match="no answer on X/control/out"):
            await Requester(client).request(
                "X/control/in", "X/control/out", {"command": "arm"}, timeout_s=0.3
            )


async def test_request_matches_answers_by_request_id(embedded_broker):
    async with (
        BrokerClient(embedded_broker, "server") as server,
        BrokerClient(embedded_broker, "asker") as asker,
    ):

        async def echo(topic_name, payload):
            import orjson

            data = orjson.loads(payload)
            await asyncio.sleep(0.05 if data["n"] == 1 else 0)
            await server.publish(
                "X/control/out", {"request_id": data["request_id"], "n": data["n"]}
            )

        await server.subscribe("X/control/in", echo)
        requester = Requester(asker)
        answers = await asyncio.gather(
            *(
                requester.request("X/control/in", "X/control/out", {"n": n}, timeout_s=5)
                for n in (1, 2, 3)
            )
        )
        assert [a["n"] for a in answers] == [1, 2, 3]


async def test_requests_made_while_the_reply_subscription_is_pending_all_get_answers(
    embedded_broker,
):
    """The second of two simultaneous first requests must not publish before the subscription."""
    async with (
        BrokerClient(embedded_broker, "server") as server,
        BrokerClient(embedded_broker, "asker") as asker,
    ):

        async def echo(topic_name, payload):
            import orjson

            data = orjson.loads(payload)
            await server.publish("Y/out", {"request_id": data["request_id"], "n": data["n"]})

        await server.subscribe("Y/in", echo)
        subscribing = asyncio.Event()
        real_subscribe = asker.subscribe

        async def slow_subscribe(*args, **kwargs):
            subscribing.set()
            await asyncio.sleep(0.3)  # a SUBACK that takes its time
            await real_subscribe(*args, **kwargs)

        asker.subscribe = slow_subscribe
        requester = Requester(asker)
        first = asyncio.create_task(requester.request("Y/in", "Y/out", {"n": 1}, timeout_s=3))
        await subscribing.wait()
        second = await requester.request("Y/in", "Y/out", {"n": 2}, timeout_s=3)
        assert second["n"] == 2 and (await first)["n"] == 1


async def test_a_message_received_but_not_yet_handled_is_delivered_again_after_a_crash(tmp_path):
    """Nothing acknowledged is lost (messaging/acks.py): a persistent session acknowledges a
    QoS 1 message once it is handled. The planner killed with an alarm received and unhandled
    used to lose it (paho acknowledged on receipt); now the broker delivers it to the next run."""
    with mosquitto(tmp_path) as url:
        started, handled = asyncio.Event(), asyncio.Queue()

        async def stuck(_topic: str, payload: bytes) -> None:
            started.set()
            await asyncio.Event().wait()  # killed before it is done with the message

        first = BrokerClient(url, "planner-like", persistent_session=True)
        await first.subscribe("QUAD_1/alarms/out", stuck)
        await first.start()
        async with BrokerClient(url, "drone") as drone:
            await drone.publish("QUAD_1/alarms/out", b"CRITICAL", qos=1)
            await asyncio.wait_for(started.wait(), 5)
        await first.stop()  # its worker is cancelled mid-handling: no PUBACK was sent

        again = BrokerClient(url, "planner-like", persistent_session=True)
        await again.subscribe("QUAD_1/alarms/out", lambda t, p: handled.put(p))
        await again.start()
        try:
            assert await asyncio.wait_for(handled.get(), 10) == b"CRITICAL"
        finally:
            await again.stop()
        # Handled this time, so acknowledged: a third run gets nothing more.
        third_got: asyncio.Queue = asyncio.Queue()
        third = BrokerClient(url, "planner-like", persistent_session=True)
        await third.subscribe("QUAD_1/alarms/out", lambda t, p: third_got.put(p))
        await third.start()
        await asyncio.sleep(1.0)
        await third.stop()
        assert third_got.empty()


async def test_overlapping_subscriptions_of_one_client_get_each_message_once(broker_url):
    """A drone's one connection holds its logger's ``<id>/#`` beside its controller's
    ``<id>/mission/in``: a broker that sends a copy per matching filter must not start a
    mission twice (the client holds only the wider filter at the broker)."""
    wide: list[bytes] = []
    narrow: list[bytes] = []

    async def on_wide(_t: str, payload: bytes) -> None:
        wide.append(payload)

    async def on_narrow(_t: str, payload: bytes) -> None:
        narrow.append(payload)

    async with BrokerClient(broker_url, "drone") as drone, BrokerClient(broker_url, "gr") as gr:
        await drone.subscribe("CAM/mission/in", on_narrow, qos=1)
        await drone.subscribe("CAM/#", on_wide, qos=0)  # wider, added after: replaces it
        await asyncio.sleep(0.3)
        for n in range(3):
            await gr.publish("CAM/mission/in", f"{n}".encode(), qos=1)
        await gr.publish("CAM/telemetry/out", b"t", qos=0)
        for _ in range(50):
            if len(wide) >= 4 and len(narrow) >= 3:
                break
            await asyncio.sleep(0.05)
        await asyncio.sleep(0.3)
    assert narrow == [b"0", b"1", b"2"]
    assert sorted(wide) == [b"0", b"1", b"2", b"t"]


def test_which_filters_cover_which() -> None:
    from dronefleet.messaging.client import covers

    assert covers("CAM/#", "CAM/mission/in") and covers("CAM/#", "CAM")
    assert covers("+/+/out", "CAM/telemetry/out") and covers("#", "+/x/#")
    assert not covers("CAM/mission/in", "CAM/#") and not covers("+/+/out", "+/#")
    assert not covers("CAM/+", "CAM/a/b") and not covers("A/#", "B/x")


async def test_a_client_stopped_and_started_again_hears_its_subscriptions(embedded_broker):
    got: asyncio.Queue = asyncio.Queue()
    client = BrokerClient(embedded_broker, "again")
    async with BrokerClient(embedded_broker, "pub") as pub:
        await client.start()
        await client.subscribe("A/control/in", lambda t, p: got.put(p))
        await client.stop()
        await client.start()
        await asyncio.sleep(0.2)
        await pub.publish("A/control/in", b"1")
        assert await asyncio.wait_for(got.get(), 5) == b"1"
        await client.stop()


async def test_a_burst_of_packets_of_every_size_comes_whole_and_in_order(broker_url):
    """paho reads through a buffer (messaging/read_buffer.py): a burst of QoS 1 packets, small
    ones many to a read and some larger than a read, each come whole, in order, once."""
    from dronefleet.messaging.read_buffer import READ_BYTES

    sizes = [(i * 7919) % 900 + 1 for i in range(1500)]
    sizes[100] = sizes[900] = READ_BYTES + 1_234  # across reads
    sizes[500] = 3 * READ_BYTES
    got: list[bytes] = []
    done = asyncio.Event()

    async def take(_topic: str, payload: bytes) -> None:
        got.append(payload)
        if len(got) == len(sizes):
            done.set()

    async with BrokerClient(broker_url, "sub") as sub, BrokerClient(broker_url, "pub") as pub:
        await sub.subscribe("burst/+", take, qos=1)
        await asyncio.sleep(0.2)
        sent = [bytes([i % 256]) * size for i, size in enumerate(sizes)]
        for i, payload in enumerate(sent):
            await pub.publish(f"burst/{i % 7}", payload, qos=1)
        await asyncio.wait_for(done.wait(), 30)
    assert got == sent


async def test_a_filter_a_persistent_session_no_longer_wants_is_unsubscribed(broker_url):
    # A resumed session keeps its subscriptions at the broker: a component of a newer version
    # that no longer subscribes a filter would be sent its messages for ever (the Mission
    # Planner's heartbeats, issue 27), unless it names the filter as retired.
    async with BrokerClient(broker_url, "planner", persistent_session=True) as old:
        await old.subscribe("+/heartbeats/out", lambda t, p: asyncio.sleep(0), qos=0)
    with pytest.raises(ValueError, match="persistent session only"):
        BrokerClient(broker_url, "planner", retired=("+/heartbeats/out",))
    async with BrokerClient(broker_url, "drone") as drone:
        assert await _sent_heartbeats(broker_url, drone, retired=())  # the old session's filter
        assert not await _sent_heartbeats(broker_url, drone, retired=("+/heartbeats/out",))
        assert not await _sent_heartbeats(broker_url, drone, retired=())  # gone for good


async def _sent_heartbeats(broker_url: str, drone: BrokerClient, retired: tuple[str, ...]) -> bool:
    """Whether the broker sends the planner's session a heartbeat, subscribed or not."""
    planner = BrokerClient(broker_url, "planner", persistent_session=True, retired=retired)
    delivered: list[str] = []
    routes = planner._routes.of
    planner._routes.of = lambda t: (delivered.append(t), routes(t))[1]  # every message it gets
    marks: asyncio.Queue = asyncio.Queue()
    await planner.subscribe("+/mark/out", lambda t, p: marks.put(p), qos=0)
    if retired:
        with pytest.raises(ValueError, match="retired"):
            await planner.subscribe(retired[0], lambda t, p: asyncio.sleep(0))
    await planner.start()  # its filters in place (and the retired ones gone) at the broker
    try:
        # In order on one link each way: a heartbeat comes before the mark published after it.
        await drone.publish("Q1/heartbeats/out", b"{}", qos=0)
        await drone.publish("Q1/mark/out", b"1", qos=0)
        assert await asyncio.wait_for(marks.get(), 10) == b"1"
    finally:
        await planner.stop()
    return "Q1/heartbeats/out" in delivered
