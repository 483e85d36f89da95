"""Telemetry ingestion shared among ground replicas (issue 27; ground/telemetry/shared_ingest.py).

A real nats-server (the embedded broker's, messaging/nats_broker.py, with users: never
anonymous) and drones publishing telemetry over MQTT: the replicas' consumers in the queue group
``ground-telemetry`` each take a share and every message is taken by exactly one; one that joins
later takes a share; two ``dronefleet ground`` processes store each message in exactly one of
their stores, and when one is killed the other stores everything after. Bad messages are counted
and dropped; a broker that is not NATS is refused."""

from __future__ import annotations

import asyncio
import sqlite3
import time
from pathlib import Path

import httpx
import pytest

from dronefleet.ground.services import GroundServices
from dronefleet.ground.telemetry.shared_ingest import IngestionNotShared, SharedIngest
from dronefleet.messaging.broker_users import BrokerRole, BrokerUsers
from dronefleet.messaging.client import QOS_STREAM, BrokerClient
from dronefleet.messaging.nats_broker import NatsBroker
from dronefleet.messaging.ports import free_port
from dronefleet.messaging.status import Telemetry
from dronefleet.messaging.url import BrokerUrl
from support.brokers import mosquitto
from support.ground_procs import wait_http
from support.nats_cluster import ClusterNode, nats_cluster
from support.postgres import fresh_database
from support.processes import dronefleet, process, stop

pytestmark = pytest.mark.integration

DRONES = [f"QUAD_{i}" for i in range(1, 6)]


class Fleet:
    """Fake drones on the broker, each publishing numbered telemetry (``vehicle_time_s`` = n)."""

    def __init__(self, urls: dict[str, BrokerUrl]) -> None:
        self.urls = urls
        self.clients: dict[str, BrokerClient] = {}
        self.sent = 0

    @classmethod
    async def on(cls, broker: NatsBroker) -> Fleet:
        return await cls({d: await broker.add_user(d, BrokerRole.DRONE) for d in DRONES}).start()

    async def start(self) -> Fleet:
        for drone, url in self.urls.items():
            self.clients[drone] = await BrokerClient(url, f"{drone}-fake").start(timeout_s=60)
        return self

    async def send(self, per_drone: int) -> set[tuple[str, int]]:
        """``per_drone`` messages from every drone; the (drone, n) sent."""
        sent = set()
        for _ in range(per_drone):
            self.sent += 1
            for drone, client in self.clients.items():
                await client.publish(
                    f"{drone}/telemetry/out", sample(drone, self.sent), qos=QOS_STREAM
                )
                sent.add((drone, self.sent))
        return sent

    async def stop(self) -> None:
        for client in self.clients.values():
            await client.stop()


def sample(drone: str, n: int) -> Telemetry:
    return Telemetry(
        drone_id=drone,
        timestamp=time.time(),
        vehicle_time_s=float(n),
        fields={"vehicle_time_s": float(n), "battery_pct": 50.0},
    )


class Taken:
    """One replica's consumer: what it was handed, as (drone, n)."""

    def __init__(self) -> None:
        self.got: list[tuple[str, int]] = []

    def take(self, message: Telemetry) -> None:
        self.got.append((message.drone_id, int(message.vehicle_time_s)))


async def until(check, timeout_s: float, what: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not check():
        if time.monotonic() > deadline:
            raise AssertionError(f"{what}: not within {timeout_s} s")
        await asyncio.sleep(0.05)


@pytest.fixture
async def nats():
    broker = NatsBroker()
    ground = broker.url_for("ground", BrokerRole.GROUND)
    async with broker:
        yield broker, ground


async def consumer(
    broker: NatsBroker | ClusterNode, ground: BrokerUrl, name: str
) -> tuple[SharedIngest, Taken]:
    taken = Taken()
    ingest = SharedIngest(broker.nats_url, ground, take=taken.take, name=name)
    return await ingest.start(), taken


async def test_replicas_split_the_telemetry_each_message_taken_once_and_a_newcomer_shares(nats):
    broker, ground = nats
    (a, got_a), (b, got_b) = [await consumer(broker, ground, n) for n in ("a", "b")]
    fleet = await Fleet.on(broker)
    c = None
    try:
        sent = await fleet.send(40)  # 200 messages
        await until(lambda: len(got_a.got) + len(got_b.got) >= len(sent), 20, "all taken")
        both = got_a.got + got_b.got
        assert sorted(both) == sorted(sent)  # every one, none twice
        assert got_a.got and got_b.got, "a replica got no share"

        c, got_c = await consumer(broker, ground, "c")  # a replica added later
        more = await fleet.send(40)
        takers = (got_a, got_b, got_c)
        await until(lambda: sum(len(t.got) for t in takers) >= len(sent | more), 20, "all taken")
        everything = [m for t in takers for m in t.got]
        assert sorted(everything) == sorted(sent | more)
        assert got_c.got and set(got_c.got) <= more, "the newcomer took no share"
        assert a.dropped == b.dropped == c.dropped == {}
    finally:
        await fleet.stop()
        for ingest in (a, b, c):
            if ingest is not None:
                await ingest.stop()


async def test_bad_telemetry_is_counted_and_dropped(nats):
    broker, ground = nats
    ingest, taken = await consumer(broker, ground, "alone")
    fleet = await Fleet.on(broker)
    try:
        quad1 = fleet.clients["QUAD_1"]
        await quad1.publish("QUAD_1/telemetry/out", b"not json", qos=QOS_STREAM)
        await quad1.publish("QUAD_1/telemetry/out", b'{"drone_id": "QUAD_1"}', qos=QOS_STREAM)
        # QUAD_1 may publish only under its own id: telemetry about another drone on its topic.
        await quad1.publish("QUAD_1/telemetry/out", sample("QUAD_2", 7), qos=QOS_STREAM)
        await quad1.publish("QUAD_1/telemetry/out", sample("QUAD_1", 8), qos=QOS_STREAM)
        await until(lambda: taken.got, 20, "the good message")  # after the bad ones, in order
        assert taken.got == [("QUAD_1", 8)]
        assert ingest.dropped == {
            "malformed telemetry": 2,
            "telemetry on another drone's topic": 1,
        }
    finally:
        await fleet.stop()
        await ingest.stop()


async def test_a_broker_that_is_not_nats_is_refused(nats, tmp_path):
    broker, ground = nats
    local = BrokerUrl.parse("local://ground:secret@bus-1")
    with pytest.raises(IngestionNotShared, match="in-process bus"):
        SharedIngest(broker.nats_url, local, take=print, name="x")
    anonymous = BrokerUrl(ground.host, ground.port)
    with pytest.raises(IngestionNotShared, match="never anonymously"):
        SharedIngest(broker.nats_url, anonymous, take=print, name="x")
    with mosquitto(tmp_path) as mqtt:
        on_mosquitto = BrokerUrl(
            mqtt.host, mqtt.port, username=ground.username, password=ground.password
        )
        # Mosquitto's port answers no NATS.
        speaks_mqtt = f"nats://{mqtt.host}:{mqtt.port}"
        with pytest.raises(IngestionNotShared, match=r"no NATS server at .* let the ground"):
            await SharedIngest(speaks_mqtt, on_mosquitto, take=print, name="x").start()
        # A real NATS server, but the drones publish on Mosquitto: it would hear nothing.
        with pytest.raises(IngestionNotShared, match="does not carry"):
            await SharedIngest(broker.nats_url, on_mosquitto, take=print, name="x").start()
    # A wrong password: refused by NATS, and said so.
    wrong = BrokerUrl(ground.host, ground.port, username=ground.username, password="wrong")
    with pytest.raises(IngestionNotShared, match=r"[Aa]uthorization"):
        await SharedIngest(broker.nats_url, wrong, take=print, name="x").start()


def stored(path: Path) -> list[tuple[str, int]]:
    if not path.exists():
        return []
    with sqlite3.connect(path) as db:
        rows = db.execute(
            "SELECT drone, value FROM telemetry WHERE field = 'vehicle_time_s'"
        ).fetchall()
    return [(drone, int(value)) for drone, value in rows]


def ground_process(broker: NatsBroker, ground: BrokerUrl, state: str, tmp: Path, name: str):
    secret = tmp / f"{name}.secret"
    secret.write_text(ground.password or "")
    http = free_port()
    cmd = dronefleet(
        "ground", "--broker", f"mqtt://{ground.username}@{ground.host}:{ground.port}",
        "--broker-password-file", str(secret), "--state", state,
        "--store", f"sqlite:///{tmp}/{name}-telemetry.db", "--photo-dir", str(tmp / f"{name}-p"),
        "--http", f"127.0.0.1:{http}", "--token=shared-ingestion-token",
        "--share-ingestion", broker.nats_url,
    )  # fmt: skip
    return cmd, f"http://127.0.0.1:{http}"


@pytest.fixture
def state():
    with fresh_database() as url:
        yield url


async def test_two_ground_processes_store_each_message_once_and_one_killed_the_other_all(
    nats, state, tmp_path
):
    broker, ground = nats
    cmd_a, http_a = ground_process(broker, ground, state, tmp_path, "a")
    cmd_b, http_b = ground_process(broker, ground, state, tmp_path, "b")
    with (
        process(cmd_a, tmp_path / "a.log") as proc_a,
        process(cmd_b, tmp_path / "b.log") as proc_b,
    ):
        await asyncio.to_thread(wait_http, http_a, 60, tmp_path / "a.log")
        await asyncio.to_thread(wait_http, http_b, 60, tmp_path / "b.log")
        store_a, store_b = tmp_path / "a-telemetry.db", tmp_path / "b-telemetry.db"
        fleet = await Fleet.on(broker)
        try:
            sent = await fleet.send(40)
            await until(
                lambda: len(stored(store_a)) + len(stored(store_b)) >= len(sent),
                30,
                "all stored",
            )
            assert sorted(stored(store_a) + stored(store_b)) == sorted(sent)
            assert stored(store_a) and stored(store_b), "a replica stored no share"

            stop(proc_b, sig_kill=True)  # b dies: the NATS server drops it from the group
            # Until the server has seen b's connection close, a message may still go to b:
            # telemetry is sent until 5 rounds in a row are all stored by a.
            streak = 0
            for _ in range(30):
                probe = await fleet.send(1)  # one message from each drone
                try:
                    await until(lambda p=probe: p <= set(stored(store_a)), 5, "a probe")
                    streak += 1
                except AssertionError:
                    streak = 0  # some went to b, not yet dropped from the group
                if streak == 5:
                    break
            assert streak == 5, "the killed replica kept its share"
            after = await fleet.send(40)
            await until(lambda: after <= set(stored(store_a)), 30, "all stored by a")
            assert not after & set(stored(store_b))
            assert len(stored(store_a)) == len(set(stored(store_a)))  # none twice
        finally:
            await fleet.stop()
        assert proc_a.poll() is None


async def test_replicas_on_two_nodes_of_a_cluster_share_a_third_nodes_drones():
    users = BrokerUsers()
    password = users.add("ground", BrokerRole.GROUND)
    passwords = {drone: users.add(drone, BrokerRole.DRONE) for drone in DRONES}
    with nats_cluster(3, users) as nodes:

        def on(node: ClusterNode, user: str, secret: str) -> BrokerUrl:
            return BrokerUrl("127.0.0.1", node.mqtt_port, username=user, password=secret)

        a, got_a = await consumer(nodes[0], on(nodes[0], "ground", password), "a")
        b, got_b = await consumer(nodes[1], on(nodes[1], "ground", password), "b")
        fleet = await Fleet({d: on(nodes[2], d, p) for d, p in passwords.items()}).start()
        try:
            sent = await fleet.send(40)
            await until(lambda: len(got_a.got) + len(got_b.got) >= len(sent), 30, "all taken")
            assert sorted(got_a.got + got_b.got) == sorted(sent)
            assert got_a.got and got_b.got, "a replica got no share"
        finally:
            await fleet.stop()
            await a.stop()
            await b.stop()


async def test_a_ground_stores_its_share_and_its_health_watches_the_nats_link(nats, tmp_path):
    broker, ground = nats
    services = GroundServices(
        ground,
        store_url=f"sqlite:///{tmp_path}/telemetry.db",
        state_path=tmp_path / "ground.db",
        http_port=0,
        token="shared-ingestion-token",
        planning_processes=0,
        share_ingestion=broker.nats_url,
    )
    await services.start()
    fleet = await Fleet.on(broker)
    try:
        assert services.connector is not None and not services.connector.from_inbox
        sent = await fleet.send(10)
        await until(lambda: sent <= set(stored(tmp_path / "telemetry.db")), 30, "all stored")
        async with httpx.AsyncClient(base_url=services.http_url, timeout=30) as http:
            assert (await http.get("/api/v1/health")).status_code == 200
            await broker.stop()  # NATS and MQTT gone: the health names the NATS link too
            await until(lambda: not services.shared_ingest.connected, 30, "the link down")
            health = await http.get("/api/v1/health")
        assert health.status_code == 503
        assert "shared ingestion (NATS)" in health.text
    finally:
        await fleet.stop()
        await services.stop()
