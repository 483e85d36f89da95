"""How many simulated drones one process carries on virtual time (issue 9).

For 10, 100 and 1000 drones — each a whole drone side (Drone Controller with its broker
connections, heartbeats every 5 vehicle s, telemetry at 5 Hz) on its own simulated vehicle — plus
the ground's Drone Identifier and Telemetry Analyzer, all on the in-process bus in one
:class:`~dronefleet.virtual_loop.VirtualTimeLoop` at ``--speedup max``, this prints:

- vehicle seconds per wall second once every drone is up (≥ 1 means real time is possible), and
  per CPU second of this process (steadier than wall time on a machine busy with other work);
- heartbeats missed: expected from each drone's interval minus those the ground received;
- telemetry messages (flight at 5 Hz, sensor readings at 2 Hz) delivered to the ground per wall
  second;
- drones marked lost by the Drone Identifier (must be 0);
- the process's resident memory;
- the machine's load average (1 min) at the end of the run: others' work slows wall time.

    .venv/bin/python bench/sim_scale.py [--drones 10 100 1000] [--vehicle-s 20] [--profile] [--wall]

``--processes K`` (issue 27, item 5): the drones spread over K worker processes the way ``dronefleet
demo`` runs them (the embedded NATS broker, each drone its own broker user and password, made for
them all at once by ``NatsBroker.urls_for``; each worker a :class:`~dronefleet.simfleet.SimFleet` on
a :class:`~dronefleet.virtual_loop.VirtualTimeLoop` paced at ``--speedup``, 1.0 = real time), and
the ground (:class:`~dronefleet.ground.services.GroundServices`, on a loop paced the same, as the
demo runs it) in a process of its own on the same broker. Per N and K it prints: start-up (wall s
from spawning the workers, which start while the drones' broker users are made, until the ground's
Drone Identifier lists every drone); then over a window of ``--vehicle-s`` / speedup wall seconds:
each worker's vehicle s per wall s (a paced loop never runs ahead; one that cannot keep up falls
behind: ``behind`` is speedup x wall s - vehicle s, and its loop lag p99 is how late, in wall ms, a
timer due every 0.1 vehicle s fired) and per CPU s of its own (steadier on a busy machine);
heartbeats missed (gaps of 1.5 intervals or more, in wall s at the speedup, as a ground-side counter
heard them); drones the ground declared lost over the whole run (must be 0); telemetry received by
the ground (its Fleet Inbox) per wall s; CPU s per wall s and RSS of each process (ground, broker,
workers).

    .venv/bin/python bench/sim_scale.py --processes 2 [--drones 100 1000] [--speedup 1]
        [--vehicle-s 20] [--warmup 5]
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import dataclasses
import math
import multiprocessing
import os
import tempfile
import time
from itertools import pairwise
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from pathlib import Path
from typing import Any

from dronefleet import virtual_loop
from dronefleet.drone.config import DroneConfig
from dronefleet.geo.types import LLA
from dronefleet.ground.identifier import EVENTS_TOPIC
from dronefleet.heap import settle_heap
from dronefleet.messaging.broker_users import BrokerRole
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.codec import decode_object
from dronefleet.messaging.embedded import EmbeddedBroker
from dronefleet.messaging.url import BrokerUrl
from dronefleet.sim.homes import homes_around
from dronefleet.simfleet import SimFleet
from mqtt_load import proc_cpu_s, proc_rss_mb

HOME = LLA(40.63, -8.659, 10.0)
HEARTBEAT_S = 5.0


def rss_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


# -- --processes K: the drones over K worker processes, the ground in one of its own ---------------

SPAWN = multiprocessing.get_context("spawn")
PROBE_S = 0.1  # a worker's lag probe: a timer every 0.1 vehicle s
STARTUP_LIMIT_S = 900.0  # wall s for every drone to be listed before the run is abandoned
DroneSpec = tuple[str, BrokerUrl, LLA]  # a drone's id, its broker user's URL, its home


def _mailbox(link: Connection) -> asyncio.Queue[Any]:
    """What comes down ``link``, as a queue on this loop (the selector watches the pipe, so a
    virtual loop's time moves on while nothing comes); ``("eof", None)`` once it is closed."""
    loop = asyncio.get_running_loop()
    queue: asyncio.Queue[Any] = asyncio.Queue()

    def readable() -> None:
        try:
            queue.put_nowait(link.recv())
        except (EOFError, OSError):
            loop.remove_reader(link.fileno())
            queue.put_nowait(("eof", None))

    loop.add_reader(link.fileno(), readable)
    return queue


async def _until(mailbox: asyncio.Queue[Any], *wanted: str) -> tuple[str, Any]:
    """The next message whose kind is one of ``wanted`` (or the end of the pipe)."""
    while True:
        kind, value = await mailbox.get()
        if kind in wanted or kind == "eof":
            return kind, value


class LagProbe:
    """How late, in wall s, a timer due every :data:`PROBE_S` vehicle s fires on a paced loop."""

    def __init__(self, speedup: float) -> None:
        self.interval_wall_s = PROBE_S / speedup
        self.lags_s: list[float] = []
        self._task = asyncio.create_task(self._run())

    async def _run(self) -> None:
        while True:
            began = time.monotonic()
            await asyncio.sleep(PROBE_S)
            self.lags_s.append(max(0.0, time.monotonic() - began - self.interval_wall_s))

    def p99_s(self) -> float:
        lags = sorted(self.lags_s)
        return lags[min(len(lags) - 1, int(0.99 * len(lags)))] if lags else float("nan")

    def stop(self) -> None:
        self._task.cancel()


def worker_process(speedup: float, link: Connection) -> None:
    """A worker: its share of the drones (sent down ``link``), paced at ``speedup``, until told
    to stop."""
    virtual_loop.run(_worker(speedup, link), speedup=speedup)


async def _worker(speedup: float, link: Connection) -> None:
    mailbox = _mailbox(link)
    kind, drones = await _until(mailbox, "drones")
    if kind == "eof":
        return
    async with SimFleet() as fleet:
        configs = [
            (DroneConfig(drone_id, heartbeat_interval_s=HEARTBEAT_S), url, home)
            for drone_id, url, home in drones
        ]
        await fleet.add_drones(configs)  # as the demo starts its drones
        settle_heap()
        link.send(("up", time.monotonic()))
        if (await _until(mailbox, "start"))[0] == "eof":
            return
        probe = LagProbe(speedup)
        v0, wall0, cpu0 = fleet.clock.now(), time.monotonic(), time.process_time()
        await _until(mailbox, "stop")
        wall_s, flown_s = time.monotonic() - wall0, fleet.clock.now() - v0
        probe.stop()
        link.send(("window", {
            "drones": len(drones),
            "vehicle_s": flown_s,
            "wall_s": wall_s,
            "behind_s": speedup * wall_s - flown_s,
            "lag_p99_s": probe.p99_s(),
            "cpu_s": time.process_time() - cpu0,
            "rss_mb": rss_mb(),
        }))  # fmt: skip


def ground_process(
    url: BrokerUrl, folder: str, expected: int, speedup: float, link: Connection
) -> None:
    """The ground services on the broker, on a loop paced at ``speedup`` (as the demo runs it)."""
    virtual_loop.run(_ground(url, Path(folder), expected, link), speedup=speedup)


async def _ground(url: BrokerUrl, folder: Path, expected: int, link: Connection) -> None:
    from dronefleet.ground.services import GroundServices

    mailbox = _mailbox(link)
    ground = GroundServices(
        url,
        store_url=f"sqlite:///{folder / 'telemetry.db'}",
        state_path=folder / "ground.db",
        serve_http=False,
    )
    await ground.start()
    try:
        link.send(("up", time.monotonic()))
        assert ground.identifier is not None and ground.inbox is not None  # started above
        fleet, feed = ground.identifier.fleet, ground.inbox.telemetry

        async def listed() -> None:
            while len(fleet) < expected:
                await asyncio.sleep(0.05)
            link.send(("listed", time.monotonic()))

        watch = asyncio.create_task(listed())
        if (await _until(mailbox, "start"))[0] == "eof":
            return
        received0, wall0, cpu0 = feed.received, time.monotonic(), time.process_time()
        await _until(mailbox, "stop")
        watch.cancel()
        wall_s = time.monotonic() - wall0
        link.send(("window", {
            "telemetry_per_wall_s": (feed.received - received0) / wall_s,
            "lost_now": sum(r.status == "lost" for r in fleet.values()),
            "listed": len(fleet),
            "cpu_s": time.process_time() - cpu0,
            "wall_s": wall_s,
            "rss_mb": rss_mb(),
        }))  # fmt: skip
    finally:
        await ground.stop()


@dataclasses.dataclass
class Hearing:
    """What the bench's own ground-side client hears: heartbeat times by drone, drones lost."""

    heard: dict[str, list[float]] = dataclasses.field(default_factory=dict)
    lost: set[str] = dataclasses.field(default_factory=set)

    async def heartbeat(self, topic_name: str, _payload: bytes) -> None:
        self.heard.setdefault(topic_name.split("/", 1)[0], []).append(time.monotonic())

    async def event(self, _topic: str, payload: bytes) -> None:
        event = decode_object(payload)
        if event.get("event") == "lost":
            self.lost.add(str(event.get("drone_id")))

    def missed(self, ids: list[str], t0: float, t1: float, interval_s: float) -> int:
        """Heartbeats missed between ``t0`` and ``t1``: gaps of 1.5 intervals or more."""
        missed = 0
        for drone_id in ids:
            times = [t0, *(t for t in self.heard.get(drone_id, []) if t0 <= t <= t1), t1]
            missed += sum(max(0, round((b - a) / interval_s) - 1) for a, b in pairwise(times))
        return missed


class Children:
    """The ground's and the workers' processes, each with its pipe; stopped however it ends."""

    def __init__(self) -> None:
        self.procs: list[tuple[BaseProcess, Connection, asyncio.Queue[Any]]] = []

    def spawn(self, target: Any, *args: Any, daemon: bool = True) -> asyncio.Queue[Any]:
        """``target(*args, pipe)`` in a new process (a daemon cannot have children: the
        ground's planning pool needs some)."""
        here, there = SPAWN.Pipe()
        proc = SPAWN.Process(target=target, args=(*args, there), daemon=daemon)
        proc.start()
        there.close()
        mailbox = _mailbox(here)
        self.procs.append((proc, here, mailbox))
        return mailbox

    def send(self, message: tuple[str, Any]) -> None:
        for proc, link, _ in self.procs:
            if proc.is_alive():
                link.send(message)

    async def stop(self) -> None:
        with contextlib.suppress(OSError):
            self.send(("stop", None))
        for proc, link, _ in reversed(self.procs):  # the workers first, the ground last
            await asyncio.to_thread(proc.join, 30)
            if proc.is_alive():
                proc.terminate()
                await asyncio.to_thread(proc.join, 5)
            asyncio.get_running_loop().remove_reader(link.fileno())
            link.close()


async def expect(mailbox: asyncio.Queue[Any], kind: str, who: str) -> Any:
    got, value = await _until(mailbox, kind)
    if got == "eof":
        raise SystemExit(f"the {who} process ended before '{kind}'")
    return value


async def measure_spread(
    count: int, processes: int, vehicle_s: float, speedup: float, warmup_s: float
) -> dict[str, Any]:
    """``count`` drones over ``processes`` workers beside the ground, on the embedded broker."""
    ids = [f"QUAD_{i + 1}" for i in range(count)]
    homes = homes_around(HOME, count)
    hearing = Hearing()
    children = Children()
    with tempfile.TemporaryDirectory(prefix="dronefleet-scale-") as tmp:
        async with EmbeddedBroker() as broker:
            ground_url = broker.url_for("ground", BrokerRole.GROUND)
            counter_url = broker.url_for("bench-counter", BrokerRole.GROUND)
            try:
                ground = children.spawn(
                    ground_process, ground_url, tmp, count, speedup, daemon=False
                )
                await expect(ground, "up", "ground")
                async with BrokerClient(counter_url, "bench-counter") as counter:
                    await counter.subscribe("+/heartbeats/out", hearing.heartbeat)
                    await counter.subscribe(EVENTS_TOPIC, hearing.event)
                    began = time.monotonic()
                    # The workers start (Python and its imports: seconds) while the drones'
                    # users are made, off this loop (hashing: seconds at 1000 drones).
                    workers = [children.spawn(worker_process, speedup) for _ in range(processes)]
                    urls = await asyncio.to_thread(broker.urls_for, ids, BrokerRole.DRONE)
                    users_s = time.monotonic() - began
                    specs = list(zip(ids, urls, homes, strict=True))
                    # Each share's URLs, passwords included, go down its worker's pipe
                    # (pickled), never on a command line.
                    for i, (proc, link, _) in enumerate(children.procs[1:]):
                        if proc.is_alive():
                            link.send(("drones", specs[i::processes]))
                    async with asyncio.timeout(STARTUP_LIMIT_S):
                        ups = [await expect(w, "up", f"worker {i}") for i, w in enumerate(workers)]
                        listed_at = await expect(ground, "listed", "ground")
                    await asyncio.sleep(warmup_s)
                    broker_pid = broker.pid or 0
                    children.send(("start", None))
                    t0, broker_cpu0 = time.monotonic(), proc_cpu_s(broker_pid)
                    await asyncio.sleep(vehicle_s / speedup)
                    children.send(("stop", None))
                    t1, broker_cpu = time.monotonic(), proc_cpu_s(broker_pid) - broker_cpu0
                    broker_rss = proc_rss_mb(broker_pid)[0]
                    window = [await expect(w, "window", "worker") for w in workers]
                    seen = await expect(ground, "window", "ground")
            finally:
                await children.stop()
    return {
        "drones": count,
        "processes": processes,
        "speedup": speedup,
        "startup_wall_s": listed_at - began,
        "workers_up_wall_s": max(ups) - began,
        "users_wall_s": users_s,  # their users made, the broker reloaded (the workers starting)
        "workers": window,
        "ground": seen,
        "heartbeats_missed": hearing.missed(ids, t0, t1, HEARTBEAT_S / speedup),
        "lost": len(hearing.lost),
        "heard": len(hearing.heard),  # drones whose heartbeats the counter heard in the run
        "broker_cpu_per_wall_s": broker_cpu / (t1 - t0),
        "broker_rss_mb": broker_rss,
        "load": os.getloadavg()[0],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--drones", type=int, nargs="+", default=[10, 100, 1000])
    parser.add_argument("--vehicle-s", type=float, default=20.0)
    parser.add_argument("--profile", action="store_true", help="print the top functions")
    parser.add_argument("--top", type=int, default=15, help="how many functions --profile prints")
    parser.add_argument("--profile-out", type=Path, help="with --profile: also save the stats here")
    parser.add_argument(
        "--wall",
        action="store_true",
        help="the way it was before virtual time: an ordinary loop, vehicles paced at 1x wall",
    )
    parser.add_argument(
        "--processes",
        type=int,
        nargs="+",
        metavar="K",
        help="the drones over K worker processes on the embedded broker, the ground in its own "
        "(one run per N and K); default: everything in this process at --speedup max",
    )
    parser.add_argument(
        "--speedup",
        type=virtual_loop.parse_speedup,
        default=1.0,
        help="with --processes: vehicle s per wall s the loops are paced at (1 = real time)",
    )
    parser.add_argument(
        "--warmup", type=float, default=5.0, help="with --processes: wall s after start-up"
    )
    args = parser.parse_args()
    if args.processes and math.isinf(args.speedup):
        # As the demo: a broker process holds messages a virtual clock at max cannot see.
        parser.error("--processes runs on the broker process: choose a finite --speedup")
    if args.processes:
        spread_main(args)
        return
    from sim_scale_local import local_main  # everything in this process

    local_main(args)


def spread_main(args: argparse.Namespace) -> None:
    print(
        f"{'drones':>6} {'K':>2} {'startup s':>9} {'veh s/wall s':>12} {'behind s':>8}"
        f" {'lag p99 ms':>10} {'hb missed':>9} {'lost':>4} {'telemetry/s':>11}"
        f" {'CPU/s ground broker workers':>27} {'RSS MB ground workers':>21} {'load':>5}"
    )
    for count in args.drones:
        for k in args.processes:
            r = asyncio.run(measure_spread(count, k, args.vehicle_s, args.speedup, args.warmup))
            print(spread_lines(r), flush=True)


def spread_lines(r: dict[str, Any]) -> str:
    """One line for the run (the slowest worker's figures), then one per worker."""
    workers, ground = r["workers"], r["ground"]
    rates = [w["vehicle_s"] / w["wall_s"] for w in workers]
    cpu = sum(w["cpu_s"] / w["wall_s"] for w in workers)
    lines = [
        f"{r['drones']:>6} {r['processes']:>2} {r['startup_wall_s']:>9.1f} {min(rates):>12.2f}"
        f" {max(w['behind_s'] for w in workers):>8.1f}"
        f" {max(w['lag_p99_s'] for w in workers) * 1000:>10.0f} {r['heartbeats_missed']:>9}"
        f" {r['lost']:>4} {ground['telemetry_per_wall_s']:>11.0f}"
        f" {ground['cpu_s'] / ground['wall_s']:>11.2f} {r['broker_cpu_per_wall_s']:>6.2f}"
        f" {cpu:>8.2f} {ground['rss_mb']:>9.0f} {max(w['rss_mb'] for w in workers):>11.0f}"
        f" {r['load']:>5.1f}"
    ]
    for i, (w, rate) in enumerate(zip(workers, rates, strict=True)):
        lines.append(
            f"         worker {i}: {w['drones']} drones, {rate:.2f} vehicle s/wall s"
            f" ({w['vehicle_s']:.1f} vehicle s in {w['wall_s']:.1f} wall s at {r['speedup']:g}x:"
            f" {w['behind_s']:.1f} behind), loop lag p99 {w['lag_p99_s'] * 1000:.0f} ms,"
            f" CPU {w['cpu_s'] / w['wall_s']:.2f} s/s ({w['vehicle_s'] / w['cpu_s']:.2f} vehicle s"
            f" per CPU s), RSS {w['rss_mb']:.0f} MB"
        )
    flown = sum(w["vehicle_s"] for w in workers) / len(workers)
    lines.append(
        f"         workers together: {sum(w['cpu_s'] for w in workers) / flown:.2f} CPU s per"
        f" vehicle s ({r['drones']} drones)"
    )
    lines.append(
        f"         ground: {ground['listed']} listed, {ground['lost_now']} lost at the end"
        f" (start-up: the drones' broker users made in {r['users_wall_s']:.1f} wall s, the"
        f" workers' drones all up after {r['workers_up_wall_s']:.1f});"
        f" broker RSS {r['broker_rss_mb']:.0f} MB"
    )
    return "\n".join(lines)


if __name__ == "__main__":
    main()
