"""Broker capacity (issue 25, item 6): many drones on one broker, embedded NATS beside Mosquitto.

For each broker in turn (the embedded default, messaging/nats_broker.py, then a Mosquitto of its
own with the password and ACL files of ``broker_acl.mosquitto_files``) it connects ``--drones``
simulated drones, each on its own TCP connection with its own credentials, and one ground
subscribed to ``+/telemetry/out`` and ``+/heartbeats/out``; then every drone sends a heartbeat
every 5 s and telemetry at 5 Hz (the project's own models: a ~16-field ``Telemetry``, a
``Heartbeat``), all at QoS 0, for ``--seconds``. It prints, per broker: the time until every drone
had its CONNACK, the rate the generator achieved and the rate delivered to the ground, the
broker's CPU seconds per 1000 messages (utime + stime from /proc/<pid>/stat) and its memory (RSS).
No assertions.

The drones are bench/mqtt_load.py's: one asyncio loop writing pre-encoded MQTT 3.1.1 packets
straight to their sockets (no client library: 1000 paho clients in threads would measure Python,
not the broker); the ground counts the PUBLISH packets it reads. A packet is skipped, and
counted, when a drone's socket buffer holds over 64 KB (the broker is not reading).

    .venv/bin/python bench/broker_capacity.py [--drones 1000] [--seconds 20]
        [--brokers nats mosquitto] [--nats-cost 4]
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import dataclasses
import os
import shutil
import subprocess
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from dronefleet.messaging.broker_acl import mosquitto_files
from dronefleet.messaging.broker_users import BrokerRole, BrokerUsers, nats_hash
from dronefleet.messaging.codec import encode
from dronefleet.messaging.common import Position
from dronefleet.messaging.nats_broker import NatsBroker
from dronefleet.messaging.ports import free_port
from dronefleet.messaging.status import BatteryStatus, FlightState, Heartbeat, Telemetry
from mqtt_load import (
    HEARTBEAT_S,
    HOST,
    TELEMETRY_HZ,
    Sent,
    connect_all,
    open_link,
    proc_cpu_s,
    proc_rss_mb,
    publish_packet,
    stream,
    subscribe,
)

# -- the brokers --------------------------------------------------------------------------------


@contextlib.asynccontextmanager
async def nats(users: BrokerUsers, folder: Path):
    async with NatsBroker(users=users) as broker:
        print(f"  nats-server {broker.pid} started in {broker.started_in_s * 1000:.0f} ms")
        assert broker.pid is not None
        yield broker.port, broker.pid


def _start_mosquitto(conf: Path) -> subprocess.Popen[bytes]:
    binary = shutil.which("mosquitto") or "/usr/sbin/mosquitto"
    if not Path(binary).exists():
        raise SystemExit("mosquitto is not installed: `make system-deps` installs it")
    return subprocess.Popen([binary, "-c", str(conf)], stderr=subprocess.DEVNULL)


@contextlib.asynccontextmanager
async def mosquitto(users: BrokerUsers, folder: Path):
    passwords, acl = mosquitto_files(users)
    for name, text in (("passwd", passwords), ("acl", acl)):
        (folder / name).write_text(text)
        (folder / name).chmod(0o600)
    port = free_port()
    user = "user root\n" if os.geteuid() == 0 else ""
    conf = folder / "mosquitto.conf"
    conf.write_text(
        f"listener {port} {HOST}\nallow_anonymous false\npersistence false\n{user}"
        f"set_tcp_nodelay true\nlog_dest file {folder}/mosquitto.log\n"
        f"password_file {folder}/passwd\nacl_file {folder}/acl\n"
    )
    began = time.perf_counter()
    proc = _start_mosquitto(conf)
    try:
        for _ in range(200):
            with contextlib.suppress(OSError):
                _, writer = await asyncio.open_connection(HOST, port)
                writer.close()
                break
            await asyncio.sleep(0.01)
        print(f"  mosquitto {proc.pid} started in {(time.perf_counter() - began) * 1000:.0f} ms")
        yield port, proc.pid
    finally:
        proc.terminate()
        proc.wait(10)


# -- the run ------------------------------------------------------------------------------------


@dataclasses.dataclass
class Result:
    broker: str
    connect_s: float = 0.0
    connect_cpu_s: float = 0.0
    failed: int = 0
    window_s: float = 0.0
    sent: int = 0
    skipped: int = 0
    delivered: int = 0
    cpu_s: float = 0.0
    rss_mb: float = 0.0
    peak_mb: float = 0.0
    generator_cpu: float = 0.0  # of one core


def payloads(drone_id: str) -> tuple[bytes, bytes]:
    """(telemetry, heartbeat) packets of one drone: the project's own messages."""
    fields = {
        "vehicle_time_s": 1234.5, "lat": 40.63312, "lon": -8.65901, "alt_m": 52.4,
        "relative_alt_m": 30.1, "vn": 1.52, "ve": -0.31, "vd": 0.02, "roll_deg": 1.4,
        "pitch_deg": -2.2, "yaw_deg": 87.3, "battery_pct": 76.5, "voltage_v": 15.8,
        "current_a": 11.2, "armed": 1.0, "in_air": 1.0,
    }  # fmt: skip
    telemetry = Telemetry(drone_id=drone_id, vehicle_time_s=1234.5, fields=fields)
    heartbeat = Heartbeat(
        drone_id=drone_id,
        vehicle_time_s=1234.5,
        position=Position(lat=40.63312, lon=-8.65901, alt_m=52.4, relative_alt_m=30.1),
        battery=BatteryStatus(remaining_pct=76.5, voltage_v=15.8, current_a=11.2),
        state=FlightState.FLYING,
        mode="GUIDED",
    )
    return (
        publish_packet(f"{drone_id}/telemetry/out", encode(telemetry)),
        publish_packet(f"{drone_id}/heartbeats/out", encode(heartbeat)),
    )


async def run(
    name: str,
    start: Callable[[BrokerUsers, Path], contextlib.AbstractAsyncContextManager[tuple[int, int]]],
    users: BrokerUsers,
    passwords: dict[str, str],
    args: argparse.Namespace,
) -> Result:
    result = Result(name)
    print(f"{name}:")
    with tempfile.TemporaryDirectory(prefix="broker-capacity-") as tmp:
        async with start(users, Path(tmp)) as (port, pid):
            ground = await open_link(port, "ground-bench", "ground", passwords["ground"])
            granted = await subscribe(ground, ["+/telemetry/out", "+/heartbeats/out"])
            if any(code & 0x80 for code in granted):
                raise SystemExit(f"{name}: the ground's subscriptions were refused: {granted!r}")
            drones = [(d, passwords[d]) for d in sorted(passwords) if d != "ground"]
            packets = [payloads(d) for d, _ in drones]
            cpu0 = proc_cpu_s(pid)
            connected = await connect_all(port, drones)
            links, result.failed, result.connect_s = (
                connected.links, connected.failed, connected.seconds
            )  # fmt: skip
            result.connect_cpu_s = proc_cpu_s(pid) - cpu0
            print(f"  {len(links)} drones connected in {result.connect_s:.2f} s "
                  f"({result.failed} failed)")  # fmt: skip
            await asyncio.sleep(1.0)
            ground.published = 0
            cpu0, mine0 = proc_cpu_s(pid), time.process_time()
            sent = Sent()
            await stream(
                links, lambda i: packets[i][0], lambda i: packets[i][1], sent, seconds=args.seconds
            )
            result.sent, result.skipped, result.window_s = sent.total, sent.skipped, sent.window_s
            await asyncio.sleep(1.0)  # what is still on its way
            result.delivered = ground.published
            result.cpu_s = proc_cpu_s(pid) - cpu0
            result.generator_cpu = (time.process_time() - mine0) / (result.window_s + 1.0)
            result.rss_mb, result.peak_mb = proc_rss_mb(pid)
            lost = sum(link.lost for link in links) + ground.lost
            if lost:
                print(f"  {lost} connections closed by the broker during the run")
            for link in [*links, ground]:
                if link.transport is not None:
                    link.transport.close()
    return result


def report(results: list[Result], drones: int, seconds: float) -> None:
    wanted = drones * (TELEMETRY_HZ + 1 / HEARTBEAT_S)
    print(f"\n{drones} drones, {seconds:g} s; wanted {wanted:,.0f} msg/s "
          f"(telemetry {TELEMETRY_HZ} Hz + a heartbeat every {HEARTBEAT_S:g} s each)")  # fmt: skip
    rows = [
        ("all connected (s)", lambda r: f"{r.connect_s:.2f}"),
        ("  broker CPU while connecting (s)", lambda r: f"{r.connect_cpu_s:.2f}"),
        ("  connections refused/failed", lambda r: f"{r.failed}"),
        ("generator sent (msg/s)", lambda r: f"{r.sent / r.window_s:,.0f}"),
        ("  skipped, broker not reading", lambda r: f"{r.skipped}"),
        ("  generator CPU (of a core)", lambda r: f"{r.generator_cpu:.0%}"),
        ("delivered to the ground (msg/s)", lambda r: f"{r.delivered / r.window_s:,.0f}"),
        ("  delivered / sent", lambda r: f"{r.delivered / max(r.sent, 1):.1%}"),
        ("broker CPU s per 1000 msgs", lambda r: f"{1000 * r.cpu_s / max(r.sent, 1):.3f}"),
        ("  broker CPU (of a core)", lambda r: f"{r.cpu_s / (r.window_s + 1.0):.0%}"),
        ("broker RSS (MB)", lambda r: f"{r.rss_mb:.0f}"),
        ("  peak RSS (MB)", lambda r: f"{r.peak_mb:.0f}"),
    ]
    print(f"{'':36}" + "".join(f"{r.broker:>14}" for r in results))
    for label, cell in rows:
        print(f"{label:36}" + "".join(f"{cell(r):>14}" for r in results))


async def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--drones", type=int, default=1000)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--brokers", nargs="+", choices=["nats", "mosquitto"],
                        default=["nats", "mosquitto"])  # fmt: skip
    parser.add_argument(
        "--nats-cost",
        type=int,
        default=None,
        help="bcrypt cost of the drones' NATS hashes (default: as made)",
    )
    args = parser.parse_args()
    began = time.perf_counter()
    users, passwords = BrokerUsers(), {}
    passwords["ground"] = users.add("ground", BrokerRole.GROUND)
    for n in range(1, args.drones + 1):
        drone_id = f"BENCH_{n:04d}"
        passwords[drone_id] = password = users.add(drone_id, BrokerRole.DRONE)
        if args.nats_cost is not None:
            user = users.get(drone_id)
            assert user is not None
            cost = args.nats_cost
            users.add_hashed(dataclasses.replace(user, nats_hash=nats_hash(password, cost=cost)))
    print(f"{args.drones + 1} users made in {time.perf_counter() - began:.1f} s")
    starts: dict[str, Callable[..., contextlib.AbstractAsyncContextManager[tuple[int, int]]]] = {
        "nats": nats,
        "mosquitto": mosquitto,
    }
    results = []
    for name in args.brokers:
        results.append(await run(name, starts[name], users, passwords, args))
    report(results, args.drones, args.seconds)


if __name__ == "__main__":
    asyncio.run(main())
