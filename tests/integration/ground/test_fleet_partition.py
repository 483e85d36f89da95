"""Ground replicas sharing the fleet by drone (issue 27: ``--partition-fleet``, ground/partition).

Real parts: the test's own Mosquitto (or the embedded NATS, the replicas reading the fleet's
stream over NATS's own protocol: ``--fleet-over-nats``), the machine's PostgreSQL, two or three
whole ``GroundServices`` in this process. Twelve fake drones send heartbeats and numbered telemetry.
Each replica must take (store) only its own drones' telemetry, every message stored once, while
seeing the whole fleet through the others' pictures; a pair of drones too close whose owners
differ is still caught; a replica that stops, or that stops renewing (hung or dead), has its
drones taken by the others; a malformed picture is counted and dropped; the option is refused
where it does not apply.
"""

from __future__ import annotations

import asyncio
import sqlite3
import time
from pathlib import Path

import pytest

from dronefleet.ground.members import RENEW_S, TTL_S
from dronefleet.ground.partition import PartitionNotApplicable, owner
from dronefleet.ground.services import GroundServices
from dronefleet.messaging.broker_users import BrokerRole, BrokerUsers
from dronefleet.messaging.client import QOS_STREAM, BrokerClient
from dronefleet.messaging.common import Position
from dronefleet.messaging.nats_broker import NatsBroker
from dronefleet.messaging.nats_link import NatsNotUsable
from dronefleet.messaging.ports import free_port
from dronefleet.messaging.status import BatteryStatus, FlightState, Heartbeat, Telemetry
from support.postgres import fresh_database

pytestmark = pytest.mark.integration

DRONES = [f"QUAD_{i}" for i in range(1, 13)]
HOME = (52.0, 4.0)  # not the seed's Braga: another home


def replica(
    broker: object, state: str, folder: Path, name: str, over_nats: str | None = None
) -> GroundServices:
    """A replica named ``ground-test-<name>``: the fleet's split among them is the same each run."""
    ground = GroundServices(
        broker,
        store_url=f"sqlite:///{folder}/{name}-telemetry.db",
        state_path=state,
        http_port=0,
        token="partition-t0ken-for-tests",
        photo_dir=folder / f"{name}-photos",
        planning_processes=0,
        serve_http=False,
        partition_fleet=True,
        fleet_over_nats=over_nats,
    )
    ground.replica_id = f"ground-test-{name}"
    return ground


class Fleet:
    """Fake drones in the air, 200 m apart on a line, but for ``close``: 2 m from ``near``."""

    def __init__(self, client: BrokerClient, close: tuple[str, str] | None = None) -> None:
        self.client = client
        self.n = 0
        self.at = {d: (HOME[0] + i * 0.0018, HOME[1]) for i, d in enumerate(DRONES)}
        if close is not None:
            near, other = close
            self.at[other] = (self.at[near][0] + 2 / 111_320, HOME[1])

    async def heartbeats(self) -> None:
        for drone, (lat, lon) in self.at.items():
            hb = Heartbeat(
                drone_id=drone,
                vehicle_time_s=float(self.n),
                position=Position(lat=lat, lon=lon, alt_m=60.0),
                battery=BatteryStatus(remaining_pct=80.0, voltage_v=16.0),
                state=FlightState.FLYING,
                mode="GUIDED",
            )
            await self.client.publish(f"{drone}/heartbeats/out", hb, qos=QOS_STREAM)

    async def telemetry(self, rounds: int) -> set[tuple[str, int]]:
        sent = set()
        for _ in range(rounds):
            self.n += 1
            for drone, (lat, lon) in self.at.items():
                fields = {"vehicle_time_s": float(self.n), "lat": lat, "lon": lon,
                          "alt_m": 60.0, "in_air": 1.0, "battery_pct": 80.0}  # fmt: skip
                msg = Telemetry(drone_id=drone, vehicle_time_s=float(self.n), fields=fields)
                await self.client.publish(f"{drone}/telemetry/out", msg, qos=QOS_STREAM)
                sent.add((drone, self.n))
            await asyncio.sleep(0.2)  # 5 Hz
        return sent


def stored(ground: GroundServices) -> list[tuple[str, int]]:
    path = Path(ground.store_url.removeprefix("sqlite:///"))
    if not path.exists():
        return []
    with sqlite3.connect(path) as db:
        rows = db.execute(
            "SELECT drone, value FROM telemetry WHERE field = 'vehicle_time_s'"
        ).fetchall()
    return [(drone, int(value)) for drone, value in rows]


async def until(check, timeout_s: float, what: str) -> float:
    start = time.monotonic()
    while not check():
        if time.monotonic() - start > timeout_s:
            raise AssertionError(f"{what}: not within {timeout_s} s")
        await asyncio.sleep(0.05)
    return time.monotonic() - start


def split(*grounds: GroundServices) -> bool:
    """Every drone known to all, and owned by exactly one of them."""
    parts = [g.partition for g in grounds]
    assert all(p is not None for p in parts)
    if any(p.drones != set(DRONES) for p in parts):  # type: ignore[union-attr]
        return False
    owned = [d for p in parts for d in p.own]  # type: ignore[union-attr]
    return sorted(owned) == sorted(DRONES)


async def settled(grounds: list[GroundServices], sent: set[tuple[str, int]]) -> None:
    async def flushed() -> None:
        for g in grounds:
            assert g.connector is not None
            await g.connector.flush()

    deadline = time.monotonic() + 20
    while True:
        await flushed()
        rows = [r for g in grounds for r in stored(g)]
        if sent <= set(rows) or time.monotonic() > deadline:
            return
        await asyncio.sleep(0.2)


@pytest.fixture(params=["mqtt", "nats"])
async def link(request, broker):
    """(the replicas' broker URL, the fake fleet's, the NATS address they read the stream at):
    Mosquitto over MQTT, or the embedded NATS with ``--fleet-over-nats`` (the fleet, anonymous
    on MQTT there, as the test's Mosquitto lets it be)."""
    if request.param == "mqtt":
        yield broker, broker, None
        return
    nats = await NatsBroker(users=BrokerUsers(), anonymous=True).start()
    try:
        ground = nats.url_for("ground", BrokerRole.GROUND)
        yield ground, f"mqtt://{nats.host}:{nats.port}", nats.nats_url
    finally:
        await nats.stop()


@pytest.fixture
def state():
    with fresh_database() as url:
        yield url


async def test_replicas_split_the_fleet_store_each_message_once_and_see_it_all(
    link, state, tmp_path
):
    broker, fleet_url, over_nats = link
    a = replica(broker, state, tmp_path, "a", over_nats)
    b = replica(broker, state, tmp_path, "b", over_nats)
    # Two drones 2 m apart whose owners differ: neither replica takes both from the broker.
    members = tuple(sorted((a.replica_id, b.replica_id)))
    near = DRONES[0]
    other = next(d for d in DRONES[1:] if owner(d, members) != owner(near, members))
    client = await BrokerClient(fleet_url, "fake-fleet").start()
    fleet = Fleet(client, close=(near, other))
    await a.start()
    await b.start()
    try:
        await fleet.heartbeats()
        await until(lambda: split(a, b), 15, "the fleet split between the replicas")
        assert a.partition and b.partition and a.partition.own and b.partition.own
        sent = await fleet.telemetry(10)
        await settled([a, b], sent)
        rows_a, rows_b = stored(a), stored(b)
        # Each message stored exactly once, by its drone's owner.
        assert sorted(rows_a + rows_b) == sorted(sent)
        assert {d for d, _ in rows_a} == a.partition.own
        assert {d for d, _ in rows_b} == b.partition.own
        # Each replica sees the whole fleet: the separation monitor's neighbours and the
        # planner's positions (the leader's), its own drones' and the other's from pictures.
        for g in (a, b):
            assert g.separation is not None
            await until(lambda g=g: set(g.separation.tracks) == set(DRONES), 5, "every track")
        leader = a if a.leading else b
        assert leader.planner is not None
        await until(lambda: set(leader.planner.latest) == set(DRONES), 5, "every position")
        # The close pair, owned apart, is caught: its owners compare their drone's messages with
        # the other's track from its picture.
        caught = sum(
            g.separation.counts.actual_breaches for g in (a, b) if g.separation is not None
        )
        assert caught >= 1, "two drones 2 m apart, owned by two replicas, were not caught"
        for g in (a, b):
            assert g.partition is not None
            health = g._partition()
            own, moved = len(g.partition.own), g.partition.moves
            assert health == {"replicas": 2, "drones": 12, "own": own, "moved": moved}
        # A replica joins: it takes a share, from both, at their next renewal.
        c = await replica(broker, state, tmp_path, "c", over_nats).start()
        try:
            await fleet.heartbeats()  # it knows a drone from its next heartbeat (every 5 s)
            await until(lambda: split(a, b, c), 5, "the fleet split among three")
            assert c.partition is not None and c.partition.own
            sent = await fleet.telemetry(3)
            await settled([a, b, c], sent)
            assert sorted(r for g in (a, b, c) for r in stored(g) if r in sent) == sorted(sent)
            assert {d for d, _ in stored(c)} == c.partition.own
        finally:
            await c.stop()
        await until(lambda: split(a, b), 5, "the fleet split between two again")
        # A replica stopped cleanly: the other takes all its drones at its next renewal.
        b_own, moved = set(b.partition.own), a.partition.moves
        await b.stop()
        took = await until(lambda: a.partition.own == set(DRONES), 5, "b's drones taken by a")
        assert a.partition.moves - moved == len(b_own)  # only b's moved
        print(f"a stopped replica's {len(b_own)} drones taken in {took:.2f} s")
        sent = await fleet.telemetry(5)
        await settled([a], sent)
        assert sent <= set(stored(a))
    finally:
        await client.stop()
        for g in (a, b):
            await g.stop()


async def test_a_replica_that_stops_renewing_loses_its_drones_and_pictures_are_checked(
    broker, state, tmp_path
):
    a = replica(broker, state, tmp_path, "a")
    c = replica(broker, state, tmp_path, "c")
    client = await BrokerClient(broker, "fake-fleet").start()
    fleet = Fleet(client)
    await a.start()
    await c.start()
    try:
        await fleet.heartbeats()
        await until(lambda: split(a, c), 15, "the fleet split between the replicas")
        assert a.partition is not None and c.partition is not None
        # c hangs: it stops renewing its row (as a dead or frozen process does) without leaving.
        renewing = c.partition.membership._task
        assert renewing is not None
        renewing.cancel()
        took = await until(lambda: a.partition.own == set(DRONES), TTL_S + 10, "c's drones")
        assert took >= TTL_S - 2 * RENEW_S, "taken before the hung replica's row expired"
        print(f"a hung replica's drones taken in {took:.2f} s (its row lasts {TTL_S} s)")
        # A picture that is not one: counted, dropped, and nothing of it taken.
        before = len(a.separation.tracks) if a.separation else 0
        bad = [b"{", b'{"replica": "x", "telemetry": [{"drone_id": "QUAD_1"}]}', b"[]"]
        for payload in bad:
            await client.publish("ground/fleet-picture/x", payload, qos=QOS_STREAM)
        await until(
            lambda: a.dropped_messages().get("malformed fleet picture", 0) == len(bad),
            10,
            "the malformed pictures counted",
        )
        assert a.separation is not None and len(a.separation.tracks) == before
    finally:
        await client.stop()
        for g in (a, c):
            await g.stop()


async def test_partitioning_is_refused_where_it_does_not_apply(broker, tmp_path):
    alone = GroundServices(
        broker,
        store_url=f"sqlite:///{tmp_path}/t.db",
        state_path=tmp_path / "ground.db",
        http_port=0,
        serve_http=False,
        partition_fleet=True,
    )
    with pytest.raises(PartitionNotApplicable, match="postgresql"):
        await alone.start()
    assert not (tmp_path / "ground.db").exists()  # refused before anything was made
    both = GroundServices(
        "mqtt://ground:secret@127.0.0.1:1",  # never reached: refused before anything starts
        store_url=f"sqlite:///{tmp_path}/t2.db",
        state_path=tmp_path / "ground2.db",
        http_port=0,
        serve_http=False,
        partition_fleet=True,
        share_ingestion="nats://127.0.0.1:2",
    )
    with pytest.raises(PartitionNotApplicable, match="--share-ingestion does not apply"):
        await both.start()


async def test_reading_the_fleet_over_nats_is_refused_where_it_does_not_apply(broker, tmp_path):
    def ground(url: str, name: str) -> GroundServices:
        return GroundServices(
            url,
            store_url=f"sqlite:///{tmp_path}/{name}.db",
            state_path=tmp_path / f"{name}-state.db",
            http_port=0,
            serve_http=False,
            fleet_over_nats=f"nats://127.0.0.1:{free_port()}",
        )

    with pytest.raises(NatsNotUsable, match="in-process bus"):
        await ground("local://ground:pw@bus-nats-refused", "local").start()
    assert not (tmp_path / "local-state.db").exists()  # refused before anything was made
    # A Mosquitto has no NATS port: nothing answers NATS there, and the ground says so.
    with pytest.raises(NatsNotUsable, match=r"no NATS server at .* let the ground"):
        await ground(f"mqtt://ground:secret@{broker.host}:{broker.port}", "mosquitto").start()
