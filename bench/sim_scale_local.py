"""``bench/sim_scale.py`` without ``--processes``: every drone and the ground in this process, on
the in-process bus, in one :class:`~dronefleet.virtual_loop.VirtualTimeLoop` (the module
docstring of sim_scale.py says what is printed)."""

from __future__ import annotations

import argparse
import asyncio
import cProfile
import os
import pstats
import tempfile
import time
from itertools import pairwise
from pathlib import Path

from dronefleet import virtual_loop
from dronefleet.drone.config import DroneConfig
from dronefleet.ground.identifier import EVENTS_TOPIC
from dronefleet.heap import settle_heap
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.codec import decode_object
from dronefleet.messaging.local_bus import LocalBus
from dronefleet.sim.homes import homes_around
from dronefleet.simfleet import SimFleet
from sim_scale import HEARTBEAT_S, HOME, rss_mb


async def measure(
    count: int, vehicle_s: float, profiler: cProfile.Profile | None = None
) -> dict[str, float]:
    from dronefleet.ground.services import GroundServices  # not in a --processes worker

    loop = asyncio.get_running_loop()
    counts = {"heartbeats": 0, "telemetry": 0}
    heard: dict[str, list[float]] = {}  # drone id -> ground times its heartbeats arrived

    async def count_heartbeat(topic_name: str, _payload: bytes) -> None:
        counts["heartbeats"] += 1
        heard.setdefault(topic_name.split("/", 1)[0], []).append(loop.time())

    async def count_telemetry(_topic: str, _payload: bytes) -> None:
        counts["telemetry"] += 1

    with tempfile.TemporaryDirectory(prefix="dronefleet-scale-") as tmp:
        async with LocalBus(anonymous=True) as broker:
            ground = GroundServices(
                broker.url,
                store_url=f"sqlite:///{Path(tmp) / 'telemetry.db'}",
                state_path=Path(tmp) / "ground.db",
                serve_http=False,
            )
            await ground.start()
            lost: list[str] = []

            async def count_lost(_topic: str, payload: bytes) -> None:
                event = decode_object(payload)
                if event.get("event") == "lost":
                    lost.append(str(event.get("drone_id")))

            try:
                async with BrokerClient(broker.url, "bench-counter") as counter:
                    await counter.subscribe("+/heartbeats/out", count_heartbeat)
                    await counter.subscribe("+/telemetry/out", count_telemetry)
                    await counter.subscribe(EVENTS_TOPIC, count_lost)
                    async with SimFleet() as fleet:
                        wall0 = time.perf_counter()
                        ids = [f"QUAD_{i + 1}" for i in range(count)]
                        for drone_id, spot in zip(ids, homes_around(HOME, count), strict=True):
                            config = DroneConfig(drone_id, heartbeat_interval_s=HEARTBEAT_S)
                            await fleet.add_drone(config, broker.url, home=spot)
                        startup_wall_s = time.perf_counter() - wall0
                        settle_heap()  # as the demo does once its drones are up
                        counts["heartbeats"] = counts["telemetry"] = 0
                        heard.clear()
                        t0, v0, wall0 = loop.time(), fleet.clock.now(), time.perf_counter()
                        cpu0 = time.process_time()
                        if profiler:
                            profiler.enable()  # the steady state only, not the start-up
                        await asyncio.sleep(vehicle_s)
                        if profiler:
                            profiler.disable()
                        wall_s = time.perf_counter() - wall0
                        cpu_s = time.process_time() - cpu0
                        elapsed_s = loop.time() - t0  # the ground's seconds (wall or virtual)
                        flown_s = fleet.clock.now() - v0
                        telemetry = counts["telemetry"]
            finally:
                await ground.stop()
    # A heartbeat is missed where two that arrived are 1.5 intervals or more apart, or where a
    # drone was not heard for that long at either end of the window.
    missed = 0
    for drone_id in ids:
        times = [t0, *heard.get(drone_id, []), t0 + elapsed_s]
        missed += sum(max(0, round((b - a) / HEARTBEAT_S) - 1) for a, b in pairwise(times))
    return {
        "drones": count,
        "startup_wall_s": startup_wall_s,
        "vehicle_s_per_wall_s": flown_s / wall_s,
        "vehicle_s_per_cpu_s": flown_s / cpu_s,
        "heartbeats_missed": missed,
        "telemetry_per_wall_s": telemetry / wall_s,
        "telemetry_per_vehicle_s": telemetry / flown_s,
        "lost": len(lost),
        "rss_mb": rss_mb(),
        "load": os.getloadavg()[0],
    }


def local_main(args: argparse.Namespace) -> None:
    """One table line per drone count (and the profile, if asked)."""
    print(
        f"{'drones':>6} {'startup wall s':>14} {'vehicle s/wall s':>16} {'vehicle s/CPU s':>15}"
        f" {'heartbeats missed':>17}"
        f" {'telemetry/wall s':>16} {'telemetry/veh s':>15} {'lost':>5} {'RSS MB':>7} {'load':>5}"
    )
    for count in args.drones:
        profiler = cProfile.Profile() if args.profile else None
        if args.wall:
            r = asyncio.run(measure(count, args.vehicle_s, profiler))
        else:
            r = virtual_loop.run(measure(count, args.vehicle_s, profiler))
        print(
            f"{r['drones']:>6} {r['startup_wall_s']:>14.1f} {r['vehicle_s_per_wall_s']:>16.2f}"
            f" {r['vehicle_s_per_cpu_s']:>15.2f} {r['heartbeats_missed']:>17}"
            f" {r['telemetry_per_wall_s']:>16.0f} {r['telemetry_per_vehicle_s']:>15.0f}"
            f" {r['lost']:>5} {r['rss_mb']:>7.0f} {r['load']:>5.1f}",
            flush=True,
        )
        if profiler:
            if args.profile_out:
                profiler.dump_stats(args.profile_out)
            pstats.Stats(profiler).sort_stats("tottime").print_stats(args.top)
