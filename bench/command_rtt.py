"""Command round trip REST -> drone -> REST (seed Fig. 4.34), with a fleet streaming telemetry.

For each fleet size (default 10 and 100 simulated drones, real time, telemetry at 5 Hz each) it
starts a Mosquitto of its own (or the embedded broker if Mosquitto is missing), the drones in a
child process (so they do not share the ground's CPU core), and the ground services in this
process; then it sends ``objrequest GPSPosition`` (a read every drone answers at once) through
``GET /api/v1/drones/{id}/objects/GPSPosition`` to random drones and reports p50/p99 round trips,
plus the telemetry points stored per second over the run.

    .venv/bin/python bench/command_rtt.py [--drones 10 100] [--requests 300] [--concurrency 4]
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import random
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx

from dronefleet.messaging.embedded import EmbeddedBroker, free_port


def tcp_nodelay_clients() -> None:
    """Set TCP_NODELAY on every MQTT client socket of this process (see --nodelay).

    Request/response over MQTT is small-packet ping-pong: with Nagle's algorithm on both ends each
    broker hop can stall for a delayed ACK (~40 ms). This patches paho for the benchmark only; the
    proper place is the one broker client (dronefleet.messaging.client).
    """
    import paho.mqtt.client as paho

    original = paho.Client._create_socket

    def create(self):  # type: ignore[no-untyped-def]
        sock = original(self)
        with contextlib.suppress(OSError, AttributeError):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        return sock

    paho.Client._create_socket = create


def _wait_port(port: int, timeout_s: float = 10.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        with contextlib.suppress(OSError), socket.create_connection(("127.0.0.1", port), 0.5):
            return
        time.sleep(0.05)
    raise TimeoutError(f"nothing on port {port}")


@contextlib.asynccontextmanager
async def broker(tmp: Path, nodelay: bool):
    exe = shutil.which("mosquitto") or "/usr/sbin/mosquitto"
    if not Path(exe).exists():  # noqa: ASYNC240 (once, before timing)
        async with EmbeddedBroker(anonymous=True) as embedded:
            yield str(embedded.url), "embedded (NATS)"
        return
    port = free_port()
    conf = tmp / "mosquitto.conf"
    conf.write_text(
        f"listener {port} 127.0.0.1\nallow_anonymous true\nset_tcp_nodelay {str(nodelay).lower()}\n"
    )
    proc = subprocess.Popen([exe, "-c", str(conf)], stderr=subprocess.DEVNULL)  # noqa: ASYNC220
    try:
        _wait_port(port)
        yield f"mqtt://127.0.0.1:{port}", "mosquitto"
    finally:
        proc.terminate()
        proc.wait(5)


async def run_drones(broker_url: str, count: int) -> None:
    """The child process: ``count`` simulated drones in one SimWorld until stdin closes."""
    from dronefleet.drone.config import DroneConfig
    from dronefleet.geo.types import LLA
    from dronefleet.sim.homes import homes_around
    from dronefleet.simfleet import SimFleet

    async with SimFleet(speedup=1.0) as fleet:
        homes = homes_around(LLA(40.63, -8.659, 10), count, spacing_m=8)
        await asyncio.gather(
            *(
                fleet.add_drone(DroneConfig(f"B{i:03d}"), broker_url, home=home)
                for i, home in enumerate(homes)
            )
        )
        print("ready", flush=True)
        await asyncio.get_running_loop().run_in_executor(None, sys.stdin.read)


async def measure(
    broker_url: str, count: int, requests: int, concurrency: int, nodelay: bool
) -> dict:
    from dronefleet.ground.services import GroundServices

    with tempfile.TemporaryDirectory() as tmp:
        ground = GroundServices(
            broker_url,
            store_url=f"sqlite:///{tmp}/telemetry.db",
            state_path=f"{tmp}/ground.db",
            http_port=0,
        )
        await ground.start()
        child = subprocess.Popen(  # noqa: ASYNC220
            [sys.executable, __file__, "--worker", str(count), "--broker", broker_url]
            + (["--nodelay"] if nodelay else []),
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
        )
        try:
            await asyncio.get_running_loop().run_in_executor(None, child.stdout.readline)
            deadline = time.monotonic() + 60
            while len(ground.identifier.fleet) < count and time.monotonic() < deadline:
                await asyncio.sleep(0.2)
            ids = sorted(ground.identifier.fleet)
            headers = {"Authorization": f"Bearer {ground.operator_token}"}
            stored0, t0 = ground.connector.stored, time.monotonic()
            rtts: list[float] = []
            errors = 0
            async with httpx.AsyncClient(base_url=ground.http_url, headers=headers) as api:

                async def worker(n: int) -> None:
                    nonlocal errors
                    for _ in range(n):
                        drone_id = random.choice(ids)
                        start = time.perf_counter()
                        r = await api.get(f"/api/v1/drones/{drone_id}/objects/GPSPosition")
                        rtts.append(time.perf_counter() - start)
                        errors += r.status_code != 200

                await asyncio.gather(*(worker(requests // concurrency) for _ in range(concurrency)))
            await asyncio.sleep(1.0)
            elapsed = time.monotonic() - t0
            stored = ground.connector.stored - stored0
        finally:
            child.stdin.close()
            child.wait(30)
            await ground.stop()
    rtts.sort()
    return {
        "drones": count,
        "online": len(ids),
        "requests": len(rtts),
        "errors": errors,
        "p50_ms": 1000 * statistics.median(rtts),
        "p99_ms": 1000 * rtts[min(len(rtts) - 1, int(0.99 * len(rtts)))],
        "points_per_s": stored / elapsed,
        "expected_points_per_s": 5.0 * count,
    }


async def main(args: argparse.Namespace) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        async with broker(Path(tmp), args.nodelay) as (url, kind):
            nagle = "TCP_NODELAY" if args.nodelay else "Nagle on (default sockets)"
            print(
                f"broker: {kind}; {nagle}; {args.requests} requests, {args.concurrency} at a time"
            )
            head = ("drones", "p50 ms", "p99 ms", "errors", "points/s", "5 Hz x N")
            print("{:>6} {:>8} {:>8} {:>6} {:>9} {:>9}".format(*head))
            for count in args.drones:
                r = await measure(url, count, args.requests, args.concurrency, args.nodelay)
                print(
                    f"{r['drones']:>6} {r['p50_ms']:>8.2f} {r['p99_ms']:>8.2f} {r['errors']:>6}"
                    f" {r['points_per_s']:>9.0f} {r['expected_points_per_s']:>9.0f}",
                    flush=True,
                )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--drones", type=int, nargs="+", default=[10, 100])
    parser.add_argument("--requests", type=int, default=300)
    parser.add_argument("--concurrency", type=int, default=4)
    parser.add_argument(
        "--nodelay", action="store_true", help="TCP_NODELAY on broker and client sockets"
    )
    parser.add_argument("--worker", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--broker", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.nodelay:
        tcp_nodelay_clients()
    if args.worker:
        asyncio.run(run_drones(args.broker, args.worker))
    else:
        asyncio.run(main(args))
