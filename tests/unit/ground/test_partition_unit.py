"""The fleet's partition among ground replicas (ground/partition.py): who owns a drone, what moves
when replicas come and go; the broker filters of a narrowed subscription; which consumers the
inbox hands own and peer messages to."""

from __future__ import annotations

import asyncio
from collections import Counter

import pytest

from dronefleet.ground.inbox import FleetInbox
from dronefleet.ground.partition import owner
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.status import Telemetry
from dronefleet.messaging.subscriptions import Subscription
from dronefleet.messaging.topic_routes import broker_filters

DRONES = [f"D{i:05d}" for i in range(3000)]
MEMBERS = ("ground-a-1f", "ground-b-2e", "ground-c-3d")


def test_every_drone_has_one_owner_the_same_whatever_the_order_and_the_fleet_is_spread():
    owners = {d: owner(d, MEMBERS) for d in DRONES}
    assert owners == {d: owner(d, MEMBERS[::-1]) for d in DRONES}
    shares = Counter(owners.values())
    assert set(shares) == set(MEMBERS)
    for member, n in shares.items():  # a third each, within a few percent
        assert 900 < n < 1100, (member, n)


def test_a_replica_leaving_moves_only_its_drones_and_one_joining_takes_only_from_others():
    before = {d: owner(d, MEMBERS) for d in DRONES}
    left = MEMBERS[:2]
    after = {d: owner(d, left) for d in DRONES}
    moved = {d for d in DRONES if before[d] != after[d]}
    assert moved == {d for d in DRONES if before[d] == MEMBERS[2]}
    joined = (*MEMBERS, "ground-d-4c")
    grown = {d: owner(d, joined) for d in DRONES}
    changed = {d for d in DRONES if grown[d] != before[d]}
    assert all(grown[d] == "ground-d-4c" for d in changed)
    assert 600 < len(changed) < 900  # about a quarter


def test_a_narrowed_subscription_is_held_as_its_filters_unless_a_wider_one_covers_them():
    async def handler(_topic: str, _payload: bytes) -> None:
        return None

    telemetry = Subscription("+/telemetry/out", handler, 0)
    telemetry.at_broker = frozenset({"QUAD_1/telemetry/out", "QUAD_2/telemetry/out"})
    assert broker_filters([telemetry]) == {"QUAD_1/telemetry/out": 0, "QUAD_2/telemetry/out": 0}
    telemetry.at_broker = frozenset()
    assert broker_filters([telemetry]) == {}
    # Another subscription of the same client that covers them: held once, at the higher QoS.
    everything = Subscription("#", handler, 0)
    telemetry.at_broker = frozenset({"QUAD_1/telemetry/out"})
    telemetry.qos = 1
    assert broker_filters([telemetry, everything]) == {"#": 1}


async def test_narrowing_refuses_a_filter_outside_the_pattern():
    client = BrokerClient("local://bus-partition-unit", "x")
    with pytest.raises(ValueError, match="not within"):
        await client.narrow("+/telemetry/out", {"QUAD_1/alarms/out"})


async def test_own_only_consumers_never_get_peer_messages_and_peers_only_never_own():
    inbox = FleetInbox("local://bus-partition-unit", client_id="x", partitioned=True)
    got: dict[str, list[tuple[str, bool]]] = {"all": [], "own": [], "peers": [], "queued": []}
    feed = inbox.telemetry
    feed.direct("all", lambda m: got["all"].append((m.drone_id, True)))
    feed.direct("own", lambda m: got["own"].append((m.drone_id, True)), takes="own")
    feed.direct("peers", lambda m: got["peers"].append((m.drone_id, True)), takes="peers")

    async def queued(m: Telemetry) -> None:
        got["queued"].append((m.drone_id, True))

    feed.queued("queued", queued, takes="own")
    mine = Telemetry(drone_id="QUAD_1", vehicle_time_s=1.0, fields={"lat": 1.0})
    theirs = Telemetry(drone_id="QUAD_2", vehicle_time_s=1.0, fields={"lat": 1.0})
    feed.hand(mine)
    feed.hand(theirs, peer=True)
    await asyncio.sleep(0.01)  # the queue's worker
    assert [d for d, _ in got["all"]] == ["QUAD_1", "QUAD_2"]
    assert [d for d, _ in got["own"]] == ["QUAD_1"]
    assert [d for d, _ in got["queued"]] == ["QUAD_1"]
    assert [d for d, _ in got["peers"]] == ["QUAD_2"]
    assert feed.received == 1  # from the broker: the own one
    await feed.close()
