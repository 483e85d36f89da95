"""Ground capacity (issue 27, item 1): one host, a thousand drones.

For each ``--drones`` N in turn: the embedded NATS broker (messaging/nats_broker.py) with N drone
users and a ground user, ``dronefleet ground`` as a subprocess on it (its own state and SQLite
telemetry store in a temporary folder), and N fake drones (bench/mqtt_load.py: each its own TCP
connection and credentials, in a process of their own so they do not slow the measuring side).
Each drone sends the project's own messages: a ``Heartbeat`` every 5 s and a 16-field
``Telemetry`` at 5 Hz, stamped at each send, hovering in the air on a grid ``--spacing-m`` apart;
it subscribes to ``<id>/gear/in`` and answers the Drone Identifier's gear queries on
``<id>/gear/out`` with what a real drone answers (drone/gear.py's GearManager, its default specs
and sensors, the ``request_id`` echoed).

After ``--warmup`` seconds (every drone heard, its gear asked), for ``--seconds`` it measures:
the ground's CPU (utime + stime of its process, every thread) per telemetry message sent; the
telemetry lag on the live stream (``/api/v1/stream?kinds=telemetry&drone=ID`` for ``--watch``
drones spread over the fleet: receive time minus the message's own timestamp); ``GET
/api/v1/drones`` at ``--poll-hz``; drones declared lost (every drone is alive throughout: any is
wrongly lost), from those answers and from the fleet events on the stream. Then the drones stop
and, once the store stops growing, the telemetry points stored (rows of field ``lat`` in the
SQLite store) are compared with those sent. Also: the ground's memory (RSS, peak), the separation
monitor's pair comparisons per telemetry message (``GET /api/v1/separation``), the messages the
ground dropped (``GET /api/v1/health``), and the host's load average (other work on the machine
shows there). No assertions.

    .venv/bin/python bench/ground_capacity.py [--drones 100 300 1000] [--seconds 30]
        [--warmup 15] [--spacing-m 200] [--watch 8] [--poll-hz 2] [--keep DIR]
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import dataclasses
import math
import multiprocessing
import os
import secrets
import shutil
import signal
import sqlite3
import sys
import tempfile
import time
from collections.abc import Callable
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

import httpx
import orjson
import websockets

from dronefleet.drone.gear import GearManager
from dronefleet.messaging.broker_users import BrokerRole, BrokerUsers
from dronefleet.messaging.codec import encode
from dronefleet.messaging.common import Position
from dronefleet.messaging.nats_broker import NatsBroker
from dronefleet.messaging.status import BatteryStatus, FlightState, Heartbeat, Telemetry
from mqtt_load import (
    HEARTBEAT_S,
    TELEMETRY_HZ,
    Link,
    Sent,
    Stamped,
    connect_all,
    proc_cpu_s,
    proc_rss_mb,
    publish_packet,
    stream,
)

HOME = (40.63312, -8.65901)
ALT_M = 52.4
_M_PER_DEG = 111_320.0
#: Stand-ins for the stamps in a message encoded once (exact in binary, so orjson writes them as
#: here); each send puts the wall time and the drone's vehicle time in their place.
MARK_TIME, MARK_VEHICLE = 987654321.125, 123456.875
MARKS = {b"987654321.125": 0, b"123456.875": 1}
# The shared counters of the fleet process: telemetry, heartbeats, skipped, gear answers.
TELEMETRY, HEARTBEATS, SKIPPED, GEAR = range(4)

# -- the fleet (its own process) -----------------------------------------------------------------


class FakeDrone:
    """One drone's messages, stamped at each send, and its answers to gear queries."""

    def __init__(self, drone_id: str, lat: float, lon: float) -> None:
        self.drone_id = drone_id
        self.boot = time.monotonic() - 600.0 * (hash(drone_id) % 1000) / 1000  # its own clock
        fields = {
            "vehicle_time_s": MARK_VEHICLE, "lat": lat, "lon": lon, "alt_m": ALT_M,
            "relative_alt_m": 30.1, "vn": 1.52, "ve": -0.31, "vd": 0.02, "roll_deg": 1.4,
            "pitch_deg": -2.2, "yaw_deg": 87.3, "battery_pct": 76.5, "voltage_v": 15.8,
            "current_a": 11.2, "armed": 1.0, "in_air": 1.0,
        }  # fmt: skip
        telemetry = Telemetry(
            drone_id=drone_id, timestamp=MARK_TIME, vehicle_time_s=MARK_VEHICLE, fields=fields
        )
        heartbeat = Heartbeat(
            drone_id=drone_id,
            timestamp=MARK_TIME,
            vehicle_time_s=MARK_VEHICLE,
            interval_s=HEARTBEAT_S,
            position=Position(lat=lat, lon=lon, alt_m=ALT_M, relative_alt_m=30.1),
            battery=BatteryStatus(remaining_pct=76.5, voltage_v=15.8, current_a=11.2),
            state=FlightState.FLYING,
            mode="GUIDED",
        )
        self._telemetry = Stamped(f"{drone_id}/telemetry/out", encode(telemetry), MARKS)
        self._heartbeat = Stamped(f"{drone_id}/heartbeats/out", encode(heartbeat), MARKS)
        self.link: Link | None = None
        self._gear: GearManager | None = None
        self.answered = 0

    def _stamps(self) -> tuple[bytes, bytes]:
        return b"%.6f" % time.time(), b"%.3f" % (time.monotonic() - self.boot)

    def telemetry(self) -> bytes:
        return self._telemetry.packet(self._stamps())

    def heartbeat(self) -> bytes:
        return self._heartbeat.packet(self._stamps())

    def on_publish(self, _topic: str, payload: bytes) -> None:
        """A gear query: answered as the drone's Gear Manager answers it."""
        task = asyncio.get_running_loop().create_task(self._answer(payload))
        _PENDING.add(task)
        task.add_done_callback(_PENDING.discard)

    async def _answer(self, payload: bytes) -> None:
        if self._gear is None:
            # Only answer() is used: no broker client, no clock (its periodic work never runs).
            self._gear = GearManager(self.drone_id, None, None, gear_dir=None)  # type: ignore[arg-type]
            self._gear.reload()
        reply = await self._gear.answer(payload)
        if self.link is not None and self.link.transport is not None:
            self.link.transport.write(publish_packet(f"{self.drone_id}/gear/out", encode(reply)))
            self.answered += 1


_PENDING: set[asyncio.Task[None]] = set()


def grid(n: int, spacing_m: float) -> list[tuple[float, float]]:
    """``n`` positions on a square grid ``spacing_m`` apart, north-east of :data:`HOME`."""
    side = math.ceil(math.sqrt(n))
    east_m_per_deg = _M_PER_DEG * math.cos(math.radians(HOME[0]))
    north_deg, east_deg = spacing_m / _M_PER_DEG, spacing_m / east_m_per_deg
    return [(HOME[0] + (i // side) * north_deg, HOME[1] + (i % side) * east_deg) for i in range(n)]


def fleet_process(
    port: int,
    drones: list[tuple[str, str]],
    spacing_m: float,
    pipe: Connection,
    stop: Any,
    counters: Any,
    talking: int | None = None,
) -> None:
    """The fake drones: connect, then stream until ``stop`` is set; reports on ``pipe``. Only
    the first ``talking`` send telemetry (all when None); the others only heartbeats."""
    asyncio.run(_fleet(port, drones, spacing_m, pipe, stop, counters, talking))


async def _fleet(
    port: int,
    drones: list[tuple[str, str]],
    spacing_m: float,
    pipe: Connection,
    stop: Any,
    counters: Any,
    talking: int | None = None,
) -> None:
    where = grid(len(drones), spacing_m)
    fakes = {d: FakeDrone(d, *where[i]) for i, (d, _) in enumerate(drones)}
    connected = await connect_all(
        port,
        drones,
        subscriptions=lambda d: [f"{d}/gear/in"],
        on_publish=lambda d: fakes[d].on_publish,
    )
    for drone_id, link in connected.of.items():
        fakes[drone_id].link = link
    flying = [fake for fake in fakes.values() if fake.link is not None]
    pipe.send(("connected", len(flying), connected.failed, connected.seconds))
    links = [fake.link for fake in flying if fake.link is not None]

    def each_tick(sent: Sent) -> None:
        counters[TELEMETRY], counters[HEARTBEATS] = sent.telemetry, sent.heartbeats
        counters[SKIPPED] = sent.skipped
        counters[GEAR] = sum(fake.answered for fake in flying)

    cpu0 = time.process_time()
    sent = Sent()
    await stream(
        links,
        lambda i: flying[i].telemetry(),
        lambda i: flying[i].heartbeat(),
        sent,
        stop=stop.is_set,
        each_tick=each_tick,
        talking=talking,
    )
    each_tick(sent)
    pipe.send(("done", (time.process_time() - cpu0) / max(sent.window_s, 1e-9)))
    for link in links:
        if link.transport is not None:
            link.transport.close()


# -- the ground (a subprocess) ---------------------------------------------------------------------


@dataclasses.dataclass
class Ground:
    proc: asyncio.subprocess.Process
    url: str
    token: str
    log_path: Path
    drain: asyncio.Task[None]

    @property
    def pid(self) -> int:
        return self.proc.pid


async def start_ground(broker: NatsBroker, password: str, folder: Path) -> Ground:
    token = secrets.token_urlsafe(24)
    log_path = folder / "ground.log"
    env = {**os.environ, "DRONEFLEET_BROKER_PASSWORD": password}
    with open(log_path, "wb") as log:  # noqa: ASYNC230 -- opened once, not read here
        proc = await asyncio.create_subprocess_exec(
            sys.executable, "-m", "dronefleet.cli", "ground",
            "--broker", f"mqtt://ground@{broker.host}:{broker.port}",
            "--state", str(folder / "ground.db"),
            "--store", f"sqlite:///{folder / 'telemetry.db'}",
            "--http", "127.0.0.1:0",
            "--token", token,
            stdout=asyncio.subprocess.PIPE, stderr=log, env=env,
        )  # fmt: skip
    assert proc.stdout is not None
    url = None
    async with asyncio.timeout(60):
        while url is None:
            line = (await proc.stdout.readline()).decode()
            if not line:
                raise SystemExit(f"the ground did not start: {log_path.read_text()[-2000:]}")
            if line.startswith("ground services on "):
                url = line.split()[3]

    async def drain() -> None:
        assert proc.stdout is not None
        while await proc.stdout.readline():
            pass

    return Ground(proc, url, token, log_path, asyncio.create_task(drain()))


async def stop_ground(ground: Ground) -> None:
    if ground.proc.returncode is None:
        ground.proc.send_signal(signal.SIGTERM)
        try:
            async with asyncio.timeout(20):
                await ground.proc.wait()
        except TimeoutError:
            ground.proc.kill()
            await ground.proc.wait()
    ground.drain.cancel()


# -- what is measured ----------------------------------------------------------------------------


@dataclasses.dataclass
class Observed:
    """What the watchers saw; lag and REST timings only while ``measuring``."""

    measuring: bool = False
    lags_s: list[float] = dataclasses.field(default_factory=list)
    rest_s: list[float] = dataclasses.field(default_factory=list)
    rest_failed: int = 0
    lost: set[str] = dataclasses.field(default_factory=set)
    listed: int = 0  # drones in the last GET /api/v1/drones
    with_gear: int = 0  # of them, with specs and sensors


async def watch_telemetry(ground: Ground, drone_id: str, seen: Observed) -> None:
    url = ground.url.replace("http", "ws", 1) + f"/api/v1/stream?kinds=telemetry&drone={drone_id}"
    headers = {"Authorization": f"Bearer {ground.token}"}
    async with websockets.connect(url, additional_headers=headers, max_size=None) as ws:
        async for raw in ws:
            now = time.time()
            if seen.measuring:
                seen.lags_s.append(now - orjson.loads(raw)["data"]["timestamp"])


async def watch_fleet(ground: Ground, seen: Observed) -> None:
    url = ground.url.replace("http", "ws", 1) + "/api/v1/stream?kinds=fleet"
    headers = {"Authorization": f"Bearer {ground.token}"}
    async with websockets.connect(url, additional_headers=headers) as ws:
        async for raw in ws:
            message = orjson.loads(raw)
            if message["data"].get("event") == "lost":
                seen.lost.add(message["drone_id"])


async def poll_drones(api: httpx.AsyncClient, hz: float, seen: Observed) -> None:
    loop = asyncio.get_running_loop()
    next_at = loop.time()
    while True:
        began = time.perf_counter()
        try:
            answer = await api.get("/api/v1/drones")
        except httpx.HTTPError:
            answer = None
        took = time.perf_counter() - began
        if seen.measuring:
            seen.rest_s.append(took)
            seen.rest_failed += answer is None or answer.status_code != 200
        if answer is not None and answer.status_code == 200:
            drones = answer.json()
            seen.listed = len(drones)
            seen.with_gear = sum(bool(d.get("specs")) and bool(d.get("sensors")) for d in drones)
            seen.lost.update(d["drone_id"] for d in drones if d["status"] == "lost")
        next_at = max(next_at + 1 / hz, loop.time())
        await asyncio.sleep(next_at - loop.time())


def thread_cpu_s(pid: int, tid: int) -> float:
    """CPU seconds of one thread of process ``pid``."""
    with open(f"/proc/{pid}/task/{tid}/stat") as stat:
        fields = stat.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def run_queue_s(pid: int) -> float:
    """Seconds the ground's main thread (its event loop) has waited for a CPU, runnable."""
    with open(f"/proc/{pid}/task/{pid}/schedstat") as stat:
        return int(stat.read().split()[1]) / 1e9


def stored_points(path: Path) -> int:
    """Telemetry points (messages) in the SQLite store: the sum of its runs' (a row is one
    drone's run of points, ground/telemetry/sqlite_store.py); 0 before it is made."""
    if not path.exists():
        return 0
    with contextlib.closing(sqlite3.connect(f"file:{path}?mode=ro", uri=True)) as db:
        try:
            return int(db.execute("SELECT COALESCE(SUM(n), 0) FROM telemetry_runs").fetchone()[0])
        except sqlite3.OperationalError:  # not made yet
            return 0


async def settled_points(path: Path, limit_s: float) -> tuple[int, float]:
    """The stored points once the count stops growing (or after ``limit_s``), and how long."""
    began, last = time.perf_counter(), -1
    while time.perf_counter() - began < limit_s:
        count = await asyncio.to_thread(stored_points, path)
        if count == last:
            break
        last = count
        await asyncio.sleep(1.0)
    return last, time.perf_counter() - began


# -- one run ----------------------------------------------------------------------------------


@dataclasses.dataclass
class Row:
    drones: int
    connected: int = 0
    connect_s: float = 0.0
    load: tuple[float, float] = (0.0, 0.0)  # 1-minute load average at the window's start, end
    window_s: float = 0.0
    telemetry_sent: int = 0  # in the window
    heartbeats_sent: int = 0
    skipped: int = 0
    generator_cpu: float = 0.0
    ground_cpu_s: float = 0.0
    waited_s: float = 0.0  # the ground's loop runnable, waiting for a CPU (other work on the host)
    loop_cpu_s: float = 0.0  # of it, the main thread's (the event loop; the rest: SQLite threads)
    stored_in_window: int = 0  # points written by the store during the window
    seen: Observed = dataclasses.field(default_factory=Observed)
    watched: int = 0
    rss_mb: float = 0.0
    peak_mb: float = 0.0
    total_sent: int = 0  # telemetry over the whole run
    stored: int = 0
    settle_s: float = 0.0
    pairs_per_message: float | None = None
    dropped: dict[str, int] = dataclasses.field(default_factory=dict)


def make_users(n: int) -> tuple[BrokerUsers, dict[str, str]]:
    users, passwords = BrokerUsers(), {}
    passwords["ground"] = users.add("ground", BrokerRole.GROUND)
    for i in range(1, n + 1):
        drone_id = f"BENCH_{i:04d}"
        passwords[drone_id] = users.add(drone_id, BrokerRole.DRONE)
    return users, passwords


async def run(n: int, args: argparse.Namespace) -> Row:
    row = Row(n)
    began = time.perf_counter()
    users, passwords = make_users(n)
    print(f"{n} drones: {n + 1} broker users made in {time.perf_counter() - began:.1f} s")
    folder = Path(tempfile.mkdtemp(prefix="ground-capacity-", dir=args.keep))
    try:
        async with NatsBroker(users=users) as broker:
            ground = await start_ground(broker, passwords["ground"], folder)
            try:
                await measure(row, broker, ground, passwords, folder, args)
            finally:
                await stop_ground(ground)
    finally:
        if args.keep is None:
            shutil.rmtree(folder, ignore_errors=True)
        else:
            print(f"  kept {folder}")
    return row


async def measure(
    row: Row,
    broker: NatsBroker,
    ground: Ground,
    passwords: dict[str, str],
    folder: Path,
    args: argparse.Namespace,
) -> None:
    spawn = multiprocessing.get_context("spawn")
    drones = [(d, p) for d, p in sorted(passwords.items()) if d != "ground"]
    here, there = spawn.Pipe()
    stop, counters = spawn.Event(), spawn.Array("q", 4, lock=False)
    fleet = spawn.Process(
        target=fleet_process,
        args=(broker.port, drones, args.spacing_m, there, stop, counters),
        daemon=True,
    )
    fleet.start()
    tasks: list[asyncio.Task[None]] = []
    try:
        _, row.connected, failed, row.connect_s = await asyncio.to_thread(here.recv)
        print(f"  {row.connected} drones connected in {row.connect_s:.2f} s ({failed} failed)")
        seen = row.seen
        headers = {"Authorization": f"Bearer {ground.token}"}
        async with httpx.AsyncClient(base_url=ground.url, headers=headers, timeout=30) as api:
            watched = [drones[i * len(drones) // args.watch][0] for i in range(args.watch)]
            row.watched = len(watched)
            tasks = [asyncio.create_task(watch_telemetry(ground, d, seen)) for d in watched]
            tasks.append(asyncio.create_task(watch_fleet(ground, seen)))
            tasks.append(asyncio.create_task(poll_drones(api, args.poll_hz, seen)))
            await asyncio.sleep(args.warmup)
            print(f"  after {args.warmup:g} s: {seen.listed} drones listed, "
                  f"{seen.with_gear} with their gear, {counters[GEAR]} gear answers")  # fmt: skip
            store = folder / "telemetry.db"
            await window(row, ground, counters, args.seconds, store, args.py_spy)
            separation = (await api.get("/api/v1/separation")).json()
            health = (await api.get("/api/v1/health")).json()
        row.dropped = health.get("dropped_messages", {})
        pairs = separation.get("pairs_compared")
        row.pairs_per_message = pairs / max(counters[TELEMETRY], 1) if pairs is not None else None
    finally:
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        stop.set()
    with contextlib.suppress(EOFError):
        _, row.generator_cpu = await asyncio.to_thread(here.recv)
    fleet.join(10)
    row.total_sent = counters[TELEMETRY]
    row.stored, row.settle_s = await settled_points(folder / "telemetry.db", args.settle)


async def profile(
    pid: int, seconds: float, folder: Path | None, drones: int
) -> asyncio.subprocess.Process | None:
    """py-spy (``pip install py-spy``, for measuring only) sampling the ground over the window:
    collapsed stacks in ``folder/ground-N.txt``."""
    if folder is None:
        return None
    spy = shutil.which("py-spy") or str(Path(sys.executable).parent / "py-spy")
    out = folder / f"ground-{drones}.txt"
    return await asyncio.create_subprocess_exec(
        spy, "record", "--pid", str(pid), "--duration", str(int(seconds)), "--rate", "50",
        "--nonblocking", "--format", "raw", "--output", str(out),
        stdout=asyncio.subprocess.DEVNULL, stderr=asyncio.subprocess.DEVNULL,
    )  # fmt: skip


async def window(
    row: Row,
    ground: Ground,
    counters: Any,
    seconds: float,
    store: Path,
    profile_to: Path | None = None,
) -> None:
    """The measuring window: the ground's CPU and the messages sent over it."""
    row.load = (os.getloadavg()[0], 0.0)
    rows0 = await asyncio.to_thread(stored_points, store)
    waited0, loop0 = run_queue_s(ground.pid), thread_cpu_s(ground.pid, ground.pid)
    cpu0, tele0, beats0, skip0 = proc_cpu_s(ground.pid), *counters[:3]
    began = time.perf_counter()
    row.seen.measuring = True
    spy = await profile(ground.pid, seconds, profile_to, row.drones)
    await asyncio.sleep(seconds)
    row.seen.measuring = False
    if spy is not None:
        await spy.wait()
    row.window_s = time.perf_counter() - began
    row.ground_cpu_s = proc_cpu_s(ground.pid) - cpu0
    row.waited_s = run_queue_s(ground.pid) - waited0
    row.loop_cpu_s = thread_cpu_s(ground.pid, ground.pid) - loop0
    row.stored_in_window = await asyncio.to_thread(stored_points, store) - rows0
    row.telemetry_sent = counters[TELEMETRY] - tele0
    row.heartbeats_sent = counters[HEARTBEATS] - beats0
    row.skipped = counters[SKIPPED] - skip0
    row.rss_mb, row.peak_mb = proc_rss_mb(ground.pid)
    row.load = (row.load[0], os.getloadavg()[0])


# -- the report ------------------------------------------------------------------------------------


def pct(values: list[float], q: float) -> float | None:
    if not values:
        return None
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q / 100 * (len(ordered) - 1)))]


def _ms(value: float | None) -> str:
    return "-" if value is None else f"{value * 1000:,.0f}"


def _s(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f}"


def streamed(r: Row) -> float:
    """The watched drones' telemetry that came on the stream in the window, of what they sent."""
    return len(r.seen.lags_s) / max(r.watched * TELEMETRY_HZ * r.window_s, 1)


def report(rows: list[Row], args: argparse.Namespace) -> None:
    print(f"\n{args.seconds:g} s measured after {args.warmup:g} s; telemetry {TELEMETRY_HZ} Hz, "
          f"a heartbeat every {HEARTBEAT_S:g} s; drones {args.spacing_m:g} m apart; "
          f"{os.cpu_count()} cores")  # fmt: skip
    table: list[tuple[str, Callable[[Row], str]]] = [
        ("drones connected", lambda r: f"{r.connected}"),
        ("load average (1 min), start/end", lambda r: f"{r.load[0]:.1f}/{r.load[1]:.1f}"),
        ("sent (msg/s)", lambda r: f"{(r.telemetry_sent + r.heartbeats_sent) / r.window_s:,.0f}"),
        ("  skipped, broker not reading", lambda r: f"{r.skipped}"),
        ("  generator CPU (of a core)", lambda r: f"{r.generator_cpu:.0%}"),
        ("ground CPU (of a core)", lambda r: f"{r.ground_cpu_s / r.window_s:.0%}"),
        ("  of it, its event loop", lambda r: f"{r.loop_cpu_s / r.window_s:.0%}"),
        ("  its loop waiting for a CPU", lambda r: f"{r.waited_s / r.window_s:.0%}"),
        ("ground CPU per telemetry msg (ms)",
         lambda r: f"{1000 * r.ground_cpu_s / max(r.telemetry_sent, 1):.3f}"),
        ("  per telemetry msg stored (ms)",
         lambda r: f"{1000 * r.ground_cpu_s / max(r.stored_in_window, 1):.3f}"),
        ("telemetry lag p50 (s)", lambda r: _s(pct(r.seen.lags_s, 50))),
        ("telemetry lag p99 (s)", lambda r: _s(pct(r.seen.lags_s, 99))),
        ("  streamed / sent (watched)", lambda r: f"{streamed(r):.0%}"),
        ("GET /api/v1/drones p50 (ms)", lambda r: _ms(pct(r.seen.rest_s, 50))),
        ("GET /api/v1/drones p99 (ms)", lambda r: _ms(pct(r.seen.rest_s, 99))),
        ("  answers / not 200", lambda r: f"{len(r.seen.rest_s)}/{r.seen.rest_failed}"),
        ("drones listed / with gear", lambda r: f"{r.seen.listed}/{r.seen.with_gear}"),
        ("drones wrongly lost", lambda r: f"{len(r.seen.lost)}"),
        ("telemetry stored / sent", lambda r: f"{r.stored / max(r.total_sent, 1):.1%}"),
        ("  store settled after (s)", lambda r: f"{r.settle_s:.0f}"),
        ("ground RSS / peak (MB)", lambda r: f"{r.rss_mb:.0f}/{r.peak_mb:.0f}"),
        ("separation pairs per telemetry msg", lambda r: _s(r.pairs_per_message)),
        ("dropped by the ground", lambda r: f"{sum(r.dropped.values())}"),
    ]  # fmt: skip
    print(f"{'':36}" + "".join(f"{r.drones:>12}" for r in rows))
    for label, cell in table:
        print(f"{label:36}" + "".join(f"{cell(r):>12}" for r in rows))
    for r in rows:
        if r.dropped:
            print(f"  dropped at {r.drones}: {r.dropped}")


async def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--drones", type=int, nargs="+", default=[100, 300, 1000])
    parser.add_argument("--seconds", type=float, default=30.0, help="the measuring window")
    parser.add_argument("--warmup", type=float, default=15.0, help="seconds before it")
    parser.add_argument("--spacing-m", type=float, default=200.0, help="between the drones")
    parser.add_argument("--watch", type=int, default=8, help="drones whose stream is timed")
    parser.add_argument("--poll-hz", type=float, default=2.0, help="GET /api/v1/drones rate")
    parser.add_argument("--settle", type=float, default=30.0, help="most seconds for the store")
    parser.add_argument("--keep", type=Path, help="keep each run's folder (logs, stores) here")
    parser.add_argument(
        "--py-spy", type=Path, help="profile the ground over the window into this folder"
    )
    args = parser.parse_args()
    rows = []
    for n in args.drones:
        rows.append(await run(n, args))
        report(rows, args)


if __name__ == "__main__":
    asyncio.run(main())
