"""The broker over TLS (issue 12): ``mqtts://`` for drones and ground, and the bridge.

A certificate authority of the test's own (trustme) signs a Mosquitto's certificate for
127.0.0.1. A client given the CA (``mqtts://…?cafile=``) connects and talks; one that does not
trust that CA, or speaks plain MQTT to the TLS port, gets nowhere. A real ``dronefleet drone``
on its own Mosquitto, bridged over TLS with the configuration ``bridge-config --cafile`` writes,
is heard at the ground broker.
"""

from __future__ import annotations

import asyncio
import subprocess

import orjson
import pytest
import trustme

from dronefleet.messaging.client import BrokerClient, BrokerUnavailable
from dronefleet.messaging.embedded import free_port
from dronefleet.messaging.url import BrokerUrl
from support.brokers import Mosquitto
from support.processes import dronefleet, process

pytestmark = pytest.mark.integration


@pytest.fixture
def tls_broker(tmp_path):
    """A Mosquitto with a TLS listener only; yields its mqtts:// URL (with the CA file)."""
    ca = trustme.CA()
    cert = ca.issue_cert("127.0.0.1")
    ca.cert_pem.write_to_path(str(tmp_path / "ca.pem"))
    cert.private_key_pem.write_to_path(str(tmp_path / "server.key"))
    cert.cert_chain_pems[0].write_to_path(str(tmp_path / "server.pem"))
    tls = (
        f"cafile {tmp_path / 'ca.pem'}\ncertfile {tmp_path / 'server.pem'}\n"
        f"keyfile {tmp_path / 'server.key'}\n"
    )
    broker = Mosquitto(tmp_path, extra_conf=tls)
    broker.start()
    try:
        yield BrokerUrl("127.0.0.1", broker.port, tls=True, ca_file=str(tmp_path / "ca.pem"))
    finally:
        broker.stop()


async def test_mqtts_with_the_ca_talks_and_without_it_nothing_connects(tls_broker):
    url = BrokerUrl.parse(tls_broker.full())
    assert url.tls and url.ca_file and url.port == tls_broker.port
    got: list[bytes] = []

    async def keep(_topic: str, payload: bytes) -> None:
        got.append(payload)

    listener = BrokerClient(url, "tls-listener")
    await listener.subscribe("QUAD_T/heartbeats/out", keep)
    await listener.start(timeout_s=10)
    talker = await BrokerClient(url, "tls-talker").start(timeout_s=10)
    try:
        await talker.publish("QUAD_T/heartbeats/out", {"hello": "tls"})
        async with asyncio.timeout(10):
            while not got:
                await asyncio.sleep(0.05)
    finally:
        await talker.stop()
        await listener.stop()
    assert orjson.loads(got[0]) == {"hello": "tls"}
    untrusted = BrokerUrl("127.0.0.1", tls_broker.port, tls=True)  # the system's CAs only
    plain = BrokerUrl("127.0.0.1", tls_broker.port)  # no TLS at all
    for url in (untrusted, plain):
        client = BrokerClient(url, "tls-stranger")
        with pytest.raises(BrokerUnavailable):
            await client.start(timeout_s=3)
        await client.stop()


async def test_a_drone_bridged_over_tls_is_heard_at_the_ground(tls_broker, tmp_path):
    args = ("bridge-config", "--drone-id", "QUAD_T", "--ground", f"127.0.0.1:{tls_broker.port}",
            "--cafile", tls_broker.ca_file)  # fmt: skip
    bridge = await asyncio.to_thread(_output, dronefleet(*args))
    assert "bridge_cafile" in bridge and "bridge_insecure false" in bridge
    drone_broker = Mosquitto(tmp_path, extra_conf=bridge, port=free_port())
    beats: list[bytes] = []

    async def keep(_topic: str, payload: bytes) -> None:
        beats.append(payload)

    ground = BrokerClient(tls_broker, "tls-ground")
    await ground.subscribe("+/heartbeats/out", keep)
    await ground.start(timeout_s=10)
    drone_broker.start()
    cmd = dronefleet("drone", "--id", "QUAD_T", "--broker", drone_broker.url.full(),
                     "--fc", "sim", "--speedup", "10")  # fmt: skip
    try:
        with process(cmd, tmp_path / "drone.log"):
            async with asyncio.timeout(30):
                while not beats:
                    await asyncio.sleep(0.1)
    finally:
        await ground.stop()
        drone_broker.stop()
    assert orjson.loads(beats[0])["drone_id"] == "QUAD_T"


def _output(cmd: list[str]) -> str:
    return subprocess.run(cmd, check=True, capture_output=True, text=True).stdout


async def test_a_broker_that_asks_for_client_certificates_takes_ours(tmp_path):
    """``mqtts://…?cafile=…&certfile=…&keyfile=…``: with Mosquitto's require_certificate, a
    client with a certificate from the fleet's CA talks; one without gets nowhere."""
    ca = trustme.CA()
    server = ca.issue_cert("127.0.0.1")
    client_cert = ca.issue_cert("quad-t.fleet.example")
    ca.cert_pem.write_to_path(str(tmp_path / "ca.pem"))
    server.private_key_pem.write_to_path(str(tmp_path / "server.key"))
    server.cert_chain_pems[0].write_to_path(str(tmp_path / "server.pem"))
    client_cert.private_key_pem.write_to_path(str(tmp_path / "client.key"))
    client_cert.cert_chain_pems[0].write_to_path(str(tmp_path / "client.pem"))
    tls = (
        f"cafile {tmp_path / 'ca.pem'}\ncertfile {tmp_path / 'server.pem'}\n"
        f"keyfile {tmp_path / 'server.key'}\nrequire_certificate true\n"
    )
    broker = Mosquitto(tmp_path, extra_conf=tls)
    broker.start()
    try:
        base = f"mqtts://127.0.0.1:{broker.port}?cafile={tmp_path / 'ca.pem'}"
        with_cert = BrokerUrl.parse(
            f"{base}&certfile={tmp_path / 'client.pem'}&keyfile={tmp_path / 'client.key'}"
        )
        assert BrokerUrl.parse(with_cert.full()) == with_cert
        client = await BrokerClient(with_cert, "tls-cert").start(timeout_s=10)
        assert await client.publish("QUAD_T/heartbeats/out", {"hello": "cert"}, timeout_s=5)
        await client.stop()
        stranger = BrokerClient(BrokerUrl.parse(base), "tls-no-cert")
        with pytest.raises(BrokerUnavailable):
            await stranger.start(timeout_s=3)
        await stranger.stop()
    finally:
        broker.stop()
