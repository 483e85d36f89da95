"""One ground replica's share of a deployment of ``--hosts`` replicas and ``--drones`` drones,
measured at that deployment's own rates (issue 27, item 4).

bench/scale_out.py runs every replica of a partitioned deployment on this machine's two cores,
so it can only offer the fleet a 2-core machine carries (1,000-2,500 drones) and fits the
4-host figure from there. What a replica of a 10,000-drone, 4-host deployment does is not that:
it takes 2,500 drones' telemetry (12,500 messages/s), every drone's heartbeats (2,000/s) and
the three other replicas' pictures of 7,500 drones (ground/picture_share.py). This bench gives
one real replica exactly that, and nothing it would not get:

- the embedded NATS broker (messaging/nats_broker.py) with a user per drone and a ground user;
- a fresh PostgreSQL state in which ``--hosts`` - 1 **stand-in replicas** hold membership rows
  (ground/members.py's own ``Membership``, renewed as a replica renews it), so the real replica
  counts ``--hosts`` replicas and owns its rendezvous share of the fleet (ground/partition.py);
- every drone connected as its own MQTT user (bench/ground_capacity.py's fleet, answering gear
  queries): the replica's own drones send telemetry at 5 Hz and heartbeats every 5 s; the
  others only heartbeats, since their telemetry goes to their owners, not to this replica;
- each stand-in publishes its drones' latest telemetry every ``SHARE_S`` on its picture topic
  as a replica's ``PictureShare`` does (the same model, topic, QoS and size limit).

**One core for the replica, as a host gives it** (``--pin``, the default on a machine of two or
more cores): the replica's process (every thread, its worker processes) runs on the first core
and nothing else does; the broker, the fleet and the stand-ins share the others. Unpinned, the
replica took what the scheduler left it beside them (0.86-0.98 core on this 2-core machine, the
machine 185-190 % busy), so whether it kept up said as much about the scheduler as about it.

After ``--warmup`` s, for ``--seconds``: the replica's CPU (every thread) per message the fleet
sends and the drones at 5 Hz one core carries at that cost; what it stored of its own drones'
telemetry; its live stream's lag; drones it holds lost. No assertions. ``--over mqtt``: the
replica reads the fleet's stream over MQTT, not NATS's own protocol (``--fleet-over-nats``).

    .venv/bin/python bench/replica_share.py [--drones 10000] [--hosts 4] [--seconds 30]
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import multiprocessing
import os
import secrets
import shutil
import signal
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx

from dronefleet.ground.members import Membership
from dronefleet.ground.partition import owner
from dronefleet.ground.picture_share import PICTURE_DRONES, SHARE_S, FleetPicture, picture_topic
from dronefleet.ground.state_pg import state_store
from dronefleet.messaging.broker_users import BrokerRole, BrokerUsers
from dronefleet.messaging.client import QOS_STREAM, BrokerClient
from dronefleet.messaging.nats_broker import NatsBroker
from dronefleet.messaging.status import Telemetry
from ground_capacity import ALT_M, TELEMETRY, fleet_process, grid, stored_points
from mqtt_load import TELEMETRY_HZ, proc_cpu_s
from scale_out import health_partition, start_replica, stream_lag_s

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from support.postgres import SHARED, fresh_database_async

SPACING_M = 200.0  # the fleet's grid, as bench/scale_out.py's
CORE = 1.0  # CPU seconds per second one host gives its replica
REPLICA_CORE = {0}  # where it runs with --pin


def stand_in_picture(replica: str, drones: list[tuple[str, float, float]]) -> list[FleetPicture]:
    """What a replica owning ``drones`` (id, lat, lon) shares each time: their latest telemetry,
    stamped now, in messages of at most ``PICTURE_DRONES``: the fleet's 16 fields
    (bench/ground_capacity.py's ``FakeDrone``)."""
    now = time.time()
    rest = {"alt_m": ALT_M, "relative_alt_m": 30.1, "vn": 1.52, "ve": -0.31, "vd": 0.02,
            "roll_deg": 1.4, "pitch_deg": -2.2, "yaw_deg": 87.3, "battery_pct": 76.5,
            "voltage_v": 15.8, "current_a": 11.2, "armed": 1.0, "in_air": 1.0}  # fmt: skip
    entries = [
        Telemetry(
            drone_id=drone_id,
            timestamp=now,
            vehicle_time_s=now % 1e5,
            fields={"vehicle_time_s": now % 1e5, "lat": lat, "lon": lon, **rest},
        )
        for drone_id, lat, lon in drones
    ]
    return [
        FleetPicture(replica=replica, telemetry=entries[i : i + PICTURE_DRONES])
        for i in range(0, len(entries), PICTURE_DRONES)
    ]


async def share_pictures(
    client: BrokerClient, owned: dict[str, list[tuple[str, float, float]]], stop: asyncio.Event
) -> int:
    """Every ``SHARE_S``, each stand-in's picture, as ground/picture_share.py sends it; the
    entries sent."""
    sent = 0
    while not stop.is_set():
        began = time.monotonic()
        for replica, drones in owned.items():
            for picture in stand_in_picture(replica, drones):
                await client.publish(
                    picture_topic(replica), picture, qos=QOS_STREAM, disposable=True
                )
                sent += len(picture.telemetry)
        await asyncio.sleep(max(0.0, SHARE_S - (time.monotonic() - began)))
    return sent


def pin(pid: int, cpus: set[int]) -> None:
    """Run process ``pid``, every thread of it and its children's, on ``cpus`` only (threads
    and processes it makes later inherit it from their maker)."""
    for task in Path(f"/proc/{pid}/task").iterdir():
        with contextlib.suppress(ProcessLookupError):
            os.sched_setaffinity(int(task.name), cpus)
    for child in Path(f"/proc/{pid}/task").glob("*/children"):
        for child_pid in child.read_text().split():
            pin(int(child_pid), cpus)


async def lost_count(url: str, token: str) -> int:
    async with httpx.AsyncClient(base_url=url, timeout=60) as http:
        fleet = await http.get("/api/v1/drones", headers={"Authorization": f"Bearer {token}"})
    return sum(d["status"] == "lost" for d in fleet.json())


async def run(args: argparse.Namespace) -> None:
    spawn = multiprocessing.get_context("spawn")
    users = BrokerUsers()
    password = users.add("ground", BrokerRole.GROUND)
    ids = [f"D{i:05d}" for i in range(args.drones)]
    secret = {d: users.add(d, BrokerRole.DRONE) for d in ids}
    folder = Path(tempfile.mkdtemp(prefix="dronefleet-replica-share-"))
    broker = NatsBroker(users=users)
    await broker.start()
    token = secrets.token_urlsafe(24)
    stop, done = spawn.Event(), asyncio.Event()
    try:
        async with fresh_database_async(args.postgres, "dronefleet_replica_share") as state_url:
            state = await state_store(state_url).open()
            stand_ins = [
                await Membership(state, name=f"stand-in-{i}", on_change=lambda _m: None).start()
                for i in range(args.hosts - 1)
            ]
            over = ["--fleet-over-nats", broker.nats_url] if args.over == "nats" else []
            proc, url = await start_replica(
                broker, password, state_url, folder, "replica", token, ["--partition-fleet", *over]
            )
            if args.pin:
                pin(proc.pid, REPLICA_CORE)
            try:
                await measure(args, spawn, broker, password, ids, secret, stand_ins,
                              proc, folder, url, token, stop, done)  # fmt: skip
            finally:
                done.set()
                stop.set()
                proc.send_signal(signal.SIGTERM)
                try:
                    async with asyncio.timeout(20):
                        await proc.wait()
                except TimeoutError:
                    proc.kill()
                for member in stand_ins:
                    await member.stop()
                await state.close()
    finally:
        await broker.stop()
        shutil.rmtree(folder, ignore_errors=True)


async def measure(
    args: argparse.Namespace,
    spawn: Any,
    broker: NatsBroker,
    password: str,
    ids: list[str],
    secret: dict[str, str],
    stand_ins: list[Membership],
    proc: asyncio.subprocess.Process,
    folder: Path,
    url: str,
    token: str,
    stop: Any,
    done: asyncio.Event,
) -> None:
    # Who owns what, as every replica computes it from the members (the stand-ins see them).
    deadline = time.monotonic() + 60
    while len(stand_ins[0].members if stand_ins else ()) != args.hosts:
        assert time.monotonic() < deadline, "the replica never joined"
        await asyncio.sleep(0.2)
    members = stand_ins[0].members if stand_ins else ()
    names = {m.name for m in stand_ins}
    replica = next(m for m in members if m not in names) if stand_ins else None
    by_owner: dict[str, list[str]] = {m: [] for m in members}
    for drone_id in ids:
        by_owner[owner(drone_id, members) if members else ""].append(drone_id)
    own = by_owner.pop(replica, ids) if replica is not None else ids
    others = [d for d in ids if d not in set(own)]
    print(f"{len(ids)} drones, {args.hosts} replicas: this one owns {len(own)}, "
          f"{len(others)} in the others' pictures")  # fmt: skip

    counters = spawn.Array("q", 4, lock=False)
    here, there = spawn.Pipe()
    order = own + others  # the first len(own) send telemetry
    where = dict(zip(order, grid(len(order), SPACING_M), strict=True))  # as the fleet places them
    fleet = spawn.Process(
        target=fleet_process,
        args=(broker.port, [(d, secret[d]) for d in order], SPACING_M, there, stop, counters,
              len(own)),
        daemon=True,
    )  # fmt: skip
    fleet.start()
    _, connected, failed, seconds = await asyncio.to_thread(here.recv)
    print(f"{connected} drones connected in {seconds:.1f} s ({failed} failed); offered "
          f"{len(own) * TELEMETRY_HZ:,} telemetry msg/s to this replica, "
          f"{len(ids) * TELEMETRY_HZ:,} by the fleet")  # fmt: skip
    sharer = BrokerClient(f"mqtt://ground:{password}@{broker.host}:{broker.port}", "stand-ins")
    await sharer.start()
    owned = {r: [(d, *where[d]) for d in drones] for r, drones in by_owner.items()}
    pictures = asyncio.create_task(share_pictures(sharer, owned, done))
    try:
        deadline = time.monotonic() + 120
        while (await health_partition(url, token)).get("own") != len(own):
            assert time.monotonic() < deadline, "the replica never took its share"
            await asyncio.sleep(0.5)
        await asyncio.sleep(args.warmup)
        store = folder / "replica.db"  # scale_out.start_replica's --store
        sent0, rows0, cpu0 = counters[TELEMETRY], stored_points(store), proc_cpu_s(proc.pid)
        began = time.monotonic()
        await asyncio.sleep(args.seconds)
        window = time.monotonic() - began
        cpu = proc_cpu_s(proc.pid) - cpu0
        sent, rows = counters[TELEMETRY] - sent0, stored_points(store) - rows0
        lag = await stream_lag_s(url, token, own[0])
        lost = await lost_count(url, token)
    finally:
        done.set()
        stop.set()
        await pictures
        await sharer.stop()
        fleet.join(10)
    fleet_rate = len(ids) * TELEMETRY_HZ  # what the whole deployment's fleet sends
    per_message = cpu / window / fleet_rate
    print(f"this replica: own telemetry sent {sent / window:,.0f} msg/s, stored "
          f"{rows / window:,.0f} msg/s ({100 * rows / max(sent, 1):.1f} %); CPU "
          f"{cpu / window:.2f} core; live stream {lag:.2f} s behind; {lost} lost")  # fmt: skip
    print(f"CPU per message the fleet sends: {per_message * 1e3:.4f} ms; one core per replica "
          f"carries {CORE / per_message / TELEMETRY_HZ:,.0f} drones at {TELEMETRY_HZ} Hz on "
          f"{args.hosts} hosts")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--drones", type=int, default=10_000)
    parser.add_argument("--hosts", type=int, default=4)
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--warmup", type=float, default=10.0)
    parser.add_argument("--postgres", default=SHARED, help="a server to make the state on")
    parser.add_argument(
        "--over",
        choices=("nats", "mqtt"),
        default="nats",
        help="how the replica reads the fleet's stream: --fleet-over-nats (default), or MQTT",
    )
    parser.add_argument(
        "--pin",
        action=argparse.BooleanOptionalAction,
        default=len(os.sched_getaffinity(0)) >= 2,
        help="the replica alone on one core, everything else on the others (default: on with "
        "two cores or more)",
    )
    args = parser.parse_args()
    if args.hosts < 1 or args.drones < 1:
        parser.error("--hosts and --drones are at least 1")
    if args.pin:
        others = os.sched_getaffinity(0) - REPLICA_CORE
        if not others or not os.sched_getaffinity(0) >= REPLICA_CORE:
            parser.error(f"--pin needs core {min(REPLICA_CORE)} and another one to run on")
        # Before anything starts: the broker, the fleet and the replica inherit it (the
        # replica is then moved to its own core).
        os.sched_setaffinity(0, others)
        print(f"the replica on core {min(REPLICA_CORE)} alone; the broker, the fleet and the "
              f"stand-ins on {sorted(others)}")  # fmt: skip
    asyncio.run(run(args))


if __name__ == "__main__":
    main()
