"""Real processes for the ground integration tests: drones, ground services, influxd, brokers.

Every process is started on free loopback ports with its output in the test's temp folder, and
is stopped (terminate, then kill) when its context ends.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import socket
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from dronefleet.messaging.embedded import free_port
from support.brokers import wait_port
from support.processes import dronefleet, process, stop  # noqa: F401 - used by the tests

INFLUXD = shutil.which("influxd") or "/usr/bin/influxd"
#: RabbitMQ's MQTT adapter as scripts/system-deps.sh sets it up (beside Mosquitto's 1883).
RABBIT_MQTT = ("127.0.0.1", int(os.environ.get("RABBIT_MQTT_PORT", "1884")))


def drone_cmd(drone_id: str, broker: str, speedup: float = 10.0) -> list[str]:
    return dronefleet(
        "drone", "--id", drone_id, "--broker", broker, "--fc", "sim",
        "--home", "40.63,-8.659,10", "--speedup", str(speedup),
    )  # fmt: skip


def ground_cmd(
    broker: str, tmp: Path, port: int, token: str, store: str | None = None
) -> list[str]:
    # --token=VALUE: a random token may start with "-", which argparse takes for an option.
    return dronefleet(
        "ground", "--broker", broker, "--store", store or f"sqlite:///{tmp}/telemetry.db",
        "--state", str(tmp / "ground.db"), "--http", f"127.0.0.1:{port}", f"--token={token}",
        "--command-timeout", "20",
    )  # fmt: skip


def wait_http(url: str, timeout_s: float = 20.0, log: Path | None = None) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        with contextlib.suppress(httpx.HTTPError):
            if httpx.get(f"{url}/api/v1/health", timeout=1).status_code == 200:
                return
        time.sleep(0.1)
    tail = log.read_text()[-2000:] if log is not None and log.exists() else ""
    raise TimeoutError(f"ground services not up at {url}; its log ends:\n{tail}")


def rabbit_mqtt_or_skip() -> tuple[str, int]:
    with contextlib.suppress(OSError), socket.create_connection(RABBIT_MQTT, timeout=1):
        return RABBIT_MQTT
    pytest.skip(f"RabbitMQ MQTT adapter not on {RABBIT_MQTT}: run scripts/system-deps.sh as root")


@contextlib.contextmanager
def influxd(tmp: Path) -> Iterator[str]:
    """A private InfluxDB 1.x on free loopback ports; yields its ``influxdb://`` store URL."""
    if not Path(INFLUXD).exists():
        pytest.skip("influxd not installed: run scripts/system-deps.sh as root")
    http_port, rpc_port = free_port(), free_port()
    root = tmp / "influxdb"
    conf = tmp / "influxdb.conf"
    conf.write_text(
        f'reporting-disabled = true\nbind-address = "127.0.0.1:{rpc_port}"\n'
        f'[meta]\n  dir = "{root}/meta"\n'
        f'[data]\n  dir = "{root}/data"\n  wal-dir = "{root}/wal"\n  query-log-enabled = false\n'
        f'[http]\n  bind-address = "127.0.0.1:{http_port}"\n  log-enabled = false\n'
        "[monitor]\n  store-enabled = false\n[subscriber]\n  enabled = false\n"
        "[continuous_queries]\n  enabled = false\n"
    )
    with process([INFLUXD, "-config", str(conf)], tmp / "influxd.log"):
        wait_port("127.0.0.1", http_port, timeout_s=20)
        yield f"influxdb://127.0.0.1:{http_port}/dronefleet"


def wait_online(api: httpx.Client, drone_id: str, timeout_s: float = 30.0) -> dict:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        r = api.get(f"/api/v1/drones/{drone_id}")
        if r.status_code == 200 and r.json()["status"] == "online":
            return r.json()
        time.sleep(0.2)
    raise AssertionError(f"{drone_id} never came online")
