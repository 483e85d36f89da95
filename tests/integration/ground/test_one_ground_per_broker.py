"""A second ``dronefleet ground`` on the same broker refuses to start (issue 11, must-show 6).

Before, both ran and the second took the first one's persistent planner session over ("Client
ground-planner is already connected, performing take-over"): progress reports were lost. A ground
that died leaves its last announcement behind; the next one waits it out and starts.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time

import httpx
import pytest

from dronefleet.messaging.embedded import free_port
from support.brokers import mosquitto
from support.processes import dronefleet

pytestmark = pytest.mark.integration


def ground(broker: str, folder, name: str) -> tuple[subprocess.Popen, int]:
    port = free_port()
    cmd = dronefleet(
        "ground", "--broker", broker, "--store", f"sqlite:///{folder}/{name}-telemetry.db",
        "--state", str(folder / f"{name}.db"), "--http", f"127.0.0.1:{port}",
        "--token", "t0ken-for-tests",
    )  # fmt: skip
    log = open(folder / f"{name}.log", "wb")  # noqa: SIM115 - closed with the process
    return subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT), port


def wait_healthy(port: int, timeout_s: float = 60) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            if httpx.get(f"http://127.0.0.1:{port}/api/v1/health", timeout=1).status_code == 200:
                return
        except httpx.HTTPError:
            pass
        time.sleep(0.2)
    raise TimeoutError(f"ground on {port} not up")


def test_a_second_ground_on_the_same_broker_refuses_and_a_dead_ones_claim_expires(tmp_path):
    with mosquitto(tmp_path) as broker:
        first, port = ground(str(broker), tmp_path, "first")
        try:
            wait_healthy(port)
            second, _ = ground(str(broker), tmp_path, "second")
            assert second.wait(timeout=60) == 2
            said = (tmp_path / "second.log").read_text()
            assert "another dronefleet ground is running" in said
            assert "Traceback" not in said
            assert first.poll() is None  # the first one is untouched
        finally:
            os.kill(first.pid, signal.SIGKILL)  # dies without clearing its claim
            first.wait()
        third, port3 = ground(str(broker), tmp_path, "third")
        try:
            wait_healthy(port3)  # the dead ground's claim went stale
        finally:
            third.terminate()
            assert third.wait(timeout=30) == 0
        fourth, port4 = ground(str(broker), tmp_path, "fourth")  # after a clean stop: at once
        try:
            wait_healthy(port4)
        finally:
            fourth.terminate()
            fourth.wait(timeout=30)
