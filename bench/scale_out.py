"""Telemetry ingestion shared among ground replicas (issue 27, item 4): throughput and CPU per
message with 1, 2 and 3 replicas' consumers over NATS.

The embedded NATS broker (messaging/nats_broker.py: MQTT for the drones, NATS's own port for the
grounds) with ``--drones`` N drone users and a ground user; N fake drones
(bench/ground_capacity.py's fleet, bench/mqtt_load.py: each its own MQTT connection, a 16-field
``Telemetry`` at 5 Hz and a heartbeat every 5 s, in a process of their own). For K = 1, 2, 3 in
turn: K consumer processes, each the ground's ingestion as ``dronefleet ground
--share-ingestion`` runs it (ground/telemetry/shared_ingest.py: the queue group
``ground-telemetry``, each message read and checked, handed to the ground's TelemetryConnector,
written in batches to an SQLite store of its own). After ``--warmup`` seconds, for ``--seconds``:
the telemetry sent, the messages each consumer took and the rows it stored, and its CPU
(utime + stime of its process) per message taken. The closing note: how many drones (5 Hz) a
4-host deployment's ingestion carries at the measured cost per message, one replica per host
given one core. It counts the storing share only: every replica still reads the whole stream
through its Fleet Inbox (live stream, separation monitor, Identifier), measured by
bench/ground_capacity.py.

With ``--replicas``, the K consumers are whole ``dronefleet ground --share-ingestion``
processes instead, replicas on one fresh PostgreSQL database (``--postgres``: a server where
the user may create databases), each with its own SQLite telemetry store: the stored share
(the points of its runs, one per message) and the CPU of the whole replica, which also reads
every message through its inbox, per message the fleet sent; K = 1 to 4 (``HOSTS``), so the
closing note gives the 4-host figure both fitted through K = 1 and 3 and as measured with 4 (on
this machine's cores, each replica far from one core at the offered rate). No assertions.

    .venv/bin/python bench/scale_out.py [--drones 1000] [--seconds 30] [--warmup 5]
    .venv/bin/python bench/scale_out.py --replicas [--drones 100] [--postgres URL]
"""

from __future__ import annotations

import argparse
import asyncio
import multiprocessing
import os
import secrets
import shutil
import signal
import sys
import tempfile
import time
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

from dronefleet.messaging.broker_users import BrokerRole, BrokerUsers
from dronefleet.messaging.nats_broker import NatsBroker
from ground_capacity import TELEMETRY, fleet_process, stored_points
from mqtt_load import TELEMETRY_HZ, proc_cpu_s

# The tests' PostgreSQL helpers: the server CI runs (DRONEFLEET_TEST_POSTGRES names another)
# and a database of the run's own, dropped after.
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from support.postgres import SHARED, fresh_database_async

HOSTS = 4  # the deployment of the closing note
CORE_PER_REPLICA = 1.0  # CPU seconds per second each host gives its replica's ingestion
TAKEN, STORED = range(2)  # a consumer's shared counters


def consumer_process(
    nats_url: str, ground_url: str, store: str, ready: Connection, counters: Any
) -> None:
    asyncio.run(_consume(nats_url, ground_url, store, ready, counters))


async def _consume(
    nats_url: str, ground_url: str, store: str, ready: Connection, counters: Any
) -> None:
    from dronefleet.ground.inbox import FleetInbox
    from dronefleet.ground.telemetry.connector import TelemetryConnector
    from dronefleet.ground.telemetry.shared_ingest import SharedIngest
    from dronefleet.ground.telemetry.store import open_store
    from dronefleet.messaging.url import BrokerUrl

    url = BrokerUrl.parse(ground_url)
    telemetry = open_store(f"sqlite:///{store}")
    await telemetry.open()
    # As GroundServices wires it: the connector fed by the shared ingestion, not by the inbox
    # (never started here: the inbox's whole-stream work is not what this measures).
    inbox = FleetInbox(url, client_id=f"bench-inbox-{os.getpid()}")
    connector = await TelemetryConnector(
        url, telemetry, client_id="bench", inbox=inbox, from_inbox=False
    ).start()
    ingest = await SharedIngest(
        nats_url, url, take=connector.take, name=f"bench-{os.getpid()}"
    ).start()
    ready.send("ready")
    while True:
        counters[TAKEN], counters[STORED] = ingest.received, connector.stored
        await asyncio.sleep(0.2)


# -- whole replicas (--replicas) ------------------------------------------------------------------


async def start_replica(
    broker: NatsBroker,
    password: str,
    state: str,
    folder: Path,
    name: str,
    token: str,
    sharing: list[str],
) -> tuple[asyncio.subprocess.Process, str]:
    """The replica's process and its web address (the replicas share their tokens); ``sharing``
    is how the replicas share the fleet (``--share-ingestion URL`` or ``--partition-fleet``)."""
    env = {**os.environ, "DRONEFLEET_BROKER_PASSWORD": password}
    log = open(folder / f"{name}.log", "wb")  # noqa: SIM115, ASYNC230 - the process's
    proc = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "dronefleet.cli", "ground",
        "--broker", f"mqtt://ground@{broker.host}:{broker.port}", "--state", state,
        "--store", f"sqlite:///{folder / name}.db", "--photo-dir", str(folder / f"{name}-photos"),
        "--http", "127.0.0.1:0", f"--token={token}",
        *sharing,
        stdout=asyncio.subprocess.PIPE, stderr=log, env=env,
    )  # fmt: skip
    log.close()
    assert proc.stdout is not None
    async with asyncio.timeout(120):
        while not (line := (await proc.stdout.readline()).decode()).startswith("ground services"):
            if not line:
                raise SystemExit(f"{name} did not start: {(folder / f'{name}.log').read_text()}")
    drain = asyncio.create_task(proc.stdout.read())  # its later output, never read
    _DRAINS.add(drain)
    return proc, line.split()[3]


async def stream_lag_s(url: str, token: str, drone: str) -> float:
    """How far behind the replica's inbox is: the live stream's latest lag (receive time minus
    the message's own timestamp) over a few of ``drone``'s messages; a replica whose CPU figure
    is low because it was starved shows here."""
    import orjson
    import websockets

    ws_url = url.replace("http", "ws", 1) + f"/api/v1/stream?kinds=telemetry&drone={drone}"
    headers = {"Authorization": f"Bearer {token}"}
    lags = []
    async with asyncio.timeout(30), websockets.connect(ws_url, additional_headers=headers) as ws:
        while len(lags) < 10:
            lags.append(time.time() - orjson.loads(await ws.recv())["data"]["timestamp"])
    return max(lags[-3:])


async def health_partition(url: str, token: str) -> dict[str, int]:
    """The replica's part of a partitioned fleet (its health's ``partition``; empty if none)."""
    import httpx

    async with httpx.AsyncClient(base_url=url, timeout=30) as http:
        answer = await http.get("/api/v1/health", headers={"Authorization": f"Bearer {token}"})
    return answer.json().get("partition") or {}


async def owned(url: str, token: str, replicas: int) -> int:
    """The drones the replica owns once it counts ``replicas`` replicas (-1 before)."""
    part = await health_partition(url, token)
    return int(part["own"]) if part.get("replicas") == replicas else -1


async def partition_of(url: str, token: str) -> str:
    """The replica's part of a partitioned fleet, said in words, or nothing."""
    part = await health_partition(url, token)
    if not part:
        return ""
    return (f"; owns {part['own']} of {part['drones']} drones among {part['replicas']} "
            f"replicas, {part['moved']} moved")  # fmt: skip


_DRAINS: set[asyncio.Task[bytes]] = set()


async def replicas_size(
    k: int,
    broker: NatsBroker,
    password: str,
    folder: Path,
    fleet_counters: Any,
    args: argparse.Namespace,
) -> tuple[int, float, float]:
    async with fresh_database_async(args.postgres, "dronefleet_scale_out") as state:
        return await _replicas_on(state, k, broker, password, folder, fleet_counters, args)


async def _replicas_on(
    state: str,
    k: int,
    broker: NatsBroker,
    password: str,
    folder: Path,
    fleet_counters: Any,
    args: argparse.Namespace,
) -> tuple[int, float, float]:
    procs, webs = [], []
    token = secrets.token_urlsafe(24)
    sharing = ["--partition-fleet"] if args.partition else ["--share-ingestion", broker.nats_url]
    if args.keep is not None:
        sharing.append("-v")  # their logs say when each took or gave up drones
    try:
        for i in range(k):
            name = f"k{k}-r{i}"
            proc, url = await start_replica(broker, password, state, folder, name, token, sharing)
            procs.append(proc)
            webs.append(url)
        stores = [folder / f"k{k}-r{i}.db" for i in range(k)]
        if args.partition:  # measured once the fleet is split: every drone owned by one
            began = time.monotonic()
            while sum([await owned(url, token, k) for url in webs]) != args.drones:
                await asyncio.sleep(0.5)
            print(f"  the fleet split among {k} replica(s) {time.monotonic() - began:.1f} s "
                  "after the last one started")  # fmt: skip
        await asyncio.sleep(args.warmup)
        sent0 = fleet_counters[TELEMETRY]
        rows0 = [stored_points(s) for s in stores]
        cpu0 = [proc_cpu_s(p.pid) for p in procs]
        began = time.monotonic()
        await asyncio.sleep(args.seconds)
        window = time.monotonic() - began
        cpu = [proc_cpu_s(p.pid) - c for p, c in zip(procs, cpu0, strict=True)]
        rows = [stored_points(s) - r for s, r in zip(stores, rows0, strict=True)]
        sent = fleet_counters[TELEMETRY] - sent0
        lags = [await stream_lag_s(url, token, "D00000") for url in webs]
        parts = [await partition_of(url, token) for url in webs]
    finally:
        for proc in procs:
            if proc.returncode is None:
                proc.send_signal(signal.SIGTERM)
        for proc in procs:
            try:
                async with asyncio.timeout(20):
                    await proc.wait()
            except TimeoutError:
                proc.kill()
                await proc.wait()
    total = sum(rows)
    print(f"{k} replica(s): sent {sent / window:,.0f} msg/s, stored {total / window:,.0f} msg/s "
          f"({100 * total / max(sent, 1):.1f} % of sent)")  # fmt: skip
    for i in range(k):
        print(f"  replica {i + 1}: stored {rows[i] / window:,.0f} msg/s, CPU {cpu[i] / window:.2f} "
              f"core, {cpu[i] / max(sent, 1) * 1e3:.3f} ms per message sent; live stream "
              f"{lags[i]:.2f} s behind{parts[i]}")  # fmt: skip
    per_sent = max(cpu) / max(sent, 1)
    return k, total / window, per_sent


async def run(args: argparse.Namespace) -> None:
    spawn = multiprocessing.get_context("spawn")
    users = BrokerUsers()
    ground_password = users.add("ground", BrokerRole.GROUND)
    drones = [(f"D{i:05d}", users.add(f"D{i:05d}", BrokerRole.DRONE)) for i in range(args.drones)]
    folder = Path(tempfile.mkdtemp(prefix="dronefleet-scale-out-"))
    broker = NatsBroker(users=users)
    await broker.start()
    ground_url = f"mqtt://ground:{ground_password}@{broker.host}:{broker.port}"
    here, there = spawn.Pipe()
    stop, fleet_counters = spawn.Event(), spawn.Array("q", 4, lock=False)
    fleet = spawn.Process(
        target=fleet_process,
        args=(broker.port, drones, 200.0, there, stop, fleet_counters),
        daemon=True,
    )
    fleet.start()
    _, connected, failed, seconds = await asyncio.to_thread(here.recv)
    print(f"{connected} drones connected in {seconds:.1f} s ({failed} failed); "
          f"offered {connected * TELEMETRY_HZ} telemetry messages/s")  # fmt: skip
    rows: list[tuple[int, float, float]] = []
    try:
        # Whole replicas up to HOSTS: the deployment of the closing note, measured as well as
        # fitted (one host's worth of CPU each is what the note assumes, not what runs here).
        for k in range(1, (HOSTS if args.replicas else 3) + 1):
            if args.replicas:
                size = replicas_size(k, broker, ground_password, folder, fleet_counters, args)
            else:
                size = one_size(k, spawn, broker, ground_url, folder, fleet_counters, args)
            rows.append(await size)
    finally:
        stop.set()
        fleet.join(10)
        await broker.stop()
        if args.keep is not None:
            shutil.copytree(folder, args.keep, dirs_exist_ok=True)  # the replicas' logs
        shutil.rmtree(folder, ignore_errors=True)
    print()
    if args.replicas:
        # A replica's cost per message the fleet sends is a part every replica pays and a part
        # shared: cost(K) = whole + share / K, fitted through K = 1 and 3. Sharing the storing
        # only, the whole part is the inbox's whole stream; partitioned (--partition), it is
        # the other replicas' pictures and the heartbeats, and the share is the own drones'
        # stream. The fleet one replica per host carries is bounded by it.
        c1, c3 = rows[0][2], rows[2][2]
        share = (c1 - c3) * 3 / 2
        whole = c1 - share
        at_hosts = whole + share / HOSTS
        drones = CORE_PER_REPLICA / at_hosts / TELEMETRY_HZ
        paid, shared = (
            ("the pictures", "its own drones") if args.partition else ("the inbox", "storing")
        )
        print(f"a whole replica's CPU per message the fleet sends: {c1 * 1e3:.3f} ms alone, "
              f"{c3 * 1e3:.3f} ms with 3: {whole * 1e3:.3f} ms every replica pays ({paid})"
              f" + {share * 1e3:.3f} ms shared ({shared})")  # fmt: skip
        print(f"{HOSTS} replicas, one per host given {CORE_PER_REPLICA:g} core: "
              f"{at_hosts * 1e3:.3f} ms each per message, {drones:,.0f} drones at "
              f"{TELEMETRY_HZ} Hz")  # fmt: skip
        c4 = rows[HOSTS - 1][2]
        print(f"measured with {HOSTS} replicas: the busiest {c4 * 1e3:.3f} ms per message, "
              f"{CORE_PER_REPLICA / c4 / TELEMETRY_HZ:,.0f} drones at {TELEMETRY_HZ} Hz "
              f"with {CORE_PER_REPLICA:g} core each")  # fmt: skip
        return
    # The cost at the highest rate per consumer (one consumer takes everything): at scale each
    # replica takes thousands of messages a second, where fixed costs (timers, batch flushes)
    # weigh least; the worst of every size bounds it from above (a loaded host inflates it).
    for what, per_message in (("one consumer taking all", rows[0][2]),
                              ("the worst of 1, 2, 3", max(r[2] for r in rows))):  # fmt: skip
        per_core = 1 / per_message
        drones = HOSTS * CORE_PER_REPLICA * per_core / TELEMETRY_HZ
        print(f"at {what}'s {per_message * 1e3:.3f} ms/message ({per_core:,.0f} per core-second):"
              f" {HOSTS} hosts, one replica each given {CORE_PER_REPLICA:g} core for its share,"
              f" take {HOSTS * per_core:,.0f} messages/s: {drones:,.0f} drones at "
              f"{TELEMETRY_HZ} Hz")  # fmt: skip
    print("  (ingestion only: each replica still reads the whole stream through its inbox)")


async def one_size(
    k: int,
    spawn: Any,
    broker: NatsBroker,
    ground_url: str,
    folder: Path,
    fleet_counters: Any,
    args: argparse.Namespace,
) -> tuple[int, float, float]:
    procs, counters, stores = [], [], []
    joined = 0  # telemetry sent before the first consumer was in the group
    for i in range(k):
        store = folder / f"k{k}-{i}.db"
        mine = spawn.Array("q", 2, lock=False)
        here, there = spawn.Pipe()
        proc = spawn.Process(
            target=consumer_process,
            args=(broker.nats_url, ground_url, str(store), there, mine),
            daemon=True,
        )
        proc.start()
        await asyncio.to_thread(here.recv)
        if i == 0:
            joined = fleet_counters[TELEMETRY]
        procs.append(proc)
        counters.append(mine)
        stores.append(store)
    try:
        await asyncio.sleep(args.warmup)
        sent0 = fleet_counters[TELEMETRY]
        taken0 = [c[TAKEN] for c in counters]
        cpu0 = [proc_cpu_s(p.pid) for p in procs]
        began = time.monotonic()
        await asyncio.sleep(args.seconds)
        window = time.monotonic() - began
        cpu = [proc_cpu_s(p.pid) - c for p, c in zip(procs, cpu0, strict=True)]
        taken = [c[TAKEN] - t for c, t in zip(counters, taken0, strict=True)]
        sent = fleet_counters[TELEMETRY] - sent0
        # Sent since the first consumer joined and not taken yet: in flight, queued, or lost
        # (the counters lag by up to 0.2 s: about a fifth of a second's messages).
        behind = fleet_counters[TELEMETRY] - joined - sum(c[TAKEN] for c in counters)
        await asyncio.sleep(1.5)  # the last batches written
        rows = [stored_points(s) for s in stores]
    finally:
        for proc in procs:
            proc.terminate()
            proc.join(10)
    per = [c / max(t, 1) for c, t in zip(cpu, taken, strict=True)]
    total = sum(taken)
    print(f"{k} replica(s): sent {sent / window:,.0f} msg/s, taken {total / window:,.0f} msg/s "
          f"({100 * total / max(sent, 1):.1f} % of sent); behind at the end: {behind:,} messages "
          f"({behind / max(sent / window, 1):.2f} s of sending)")  # fmt: skip
    for i in range(k):
        print(f"  replica {i + 1}: {taken[i] / window:,.0f} msg/s, CPU {cpu[i] / window:.2f} "
              f"core, {per[i] * 1e3:.3f} ms/message; {rows[i]:,} rows stored in all")  # fmt: skip
    overall = sum(cpu) / max(total, 1)
    print(f"  all {k}: CPU {sum(cpu) / window:.2f} core, {overall * 1e3:.3f} ms/message")
    return k, total / window, overall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--drones", type=int, default=1000)
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--warmup", type=float, default=5.0)
    parser.add_argument("--replicas", action="store_true", help="whole dronefleet ground replicas")
    parser.add_argument(
        "--partition",
        action="store_true",
        help="with --replicas: the replicas share the fleet by drone (--partition-fleet) "
        "instead of sharing only the storing (--share-ingestion)",
    )
    parser.add_argument("--keep", type=Path, help="keep the replicas' logs and stores here")
    parser.add_argument("--postgres", default=SHARED, help="a server to make the state on")
    args = parser.parse_args()
    load = " ".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"load average before: {load}, {os.cpu_count()} cores")
    asyncio.run(run(args))
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
