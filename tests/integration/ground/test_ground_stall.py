"""A ground stopped for 30 s comes back answering, and its stall costs the fleet nothing (issue 26,
item 6). Real processes: Mosquitto, ``dronefleet ground``, two ``dronefleet drone --fc sim``
flying an area mission given over REST, and two busy loops beside them on this machine's cores.

Measured before: a ground SIGSTOPped 30 s and SIGCONTed sent its drones home (it took its own
stall for their silence), and once it hung for good (no HTTP, 1 GB) while the drones finished:
a publish retry loop that never yielded (messaging/client.py, since fixed: every retry sleeps).
Now, after SIGCONT: the REST API answers within 2 s (the figure is printed), nobody is declared
lost or sent home for the ground's own stall, and the mission completes with every waypoint
flown once.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator

import httpx
import pytest

from dronefleet.experiments import scenarios
from dronefleet.messaging.embedded import free_port
from support.brokers import mosquitto
from support.ground_procs import ground_cmd, process, wait_http, wait_online
from support.missions import flown_as_planned
from support.processes import dronefleet

pytestmark = pytest.mark.integration

SPEEDUP = 3.0
DRONES = {"STALL_1": "40.63,-8.659,10", "STALL_2": "40.63,-8.6588,10"}
STALL_S = 30.0


@contextlib.contextmanager
def busy_cores() -> Iterator[None]:
    """Two processes that only burn CPU, beside the ones under test (killed after)."""
    loops = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(2)]
    try:
        yield
    finally:
        for loop in loops:
            loop.kill()
            loop.wait()


def drone(drone_id: str, broker: str) -> list[str]:
    return dronefleet(
        "drone", "--id", drone_id, "--broker", broker, "--fc", "sim",
        "--home", DRONES[drone_id], "--speedup", str(SPEEDUP),
    )  # fmt: skip


class Watch:
    """Polls the fleet every 0.2 s from its own thread: every status each drone was seen in."""

    def __init__(self, url: str, token: str) -> None:
        self.http = httpx.Client(
            base_url=url, headers={"Authorization": f"Bearer {token}"}, timeout=60
        )
        self.seen: dict[str, set[str]] = {d: set() for d in DRONES}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                for d in self.http.get("/api/v1/drones").json():
                    self.seen.setdefault(d["drone_id"], set()).add(d["status"])
            except httpx.HTTPError:
                pass
            time.sleep(0.2)

    def __enter__(self) -> Watch:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(70)
        self.http.close()


def first_answer_s(url: str, token: str, limit_s: float = 60.0) -> float:
    """Seconds until ``GET /api/v1/drones`` is answered (200): one request, made at once and
    waited for, asked again only if it fails."""
    started = time.monotonic()
    with httpx.Client(base_url=url, headers={"Authorization": f"Bearer {token}"}) as http:
        while time.monotonic() - started < limit_s:
            try:
                if http.get("/api/v1/drones", timeout=limit_s).status_code == 200:
                    return time.monotonic() - started
            except httpx.HTTPError:
                pass
            time.sleep(0.05)
    return float("inf")


def test_a_ground_stopped_30_s_answers_at_once_and_its_stall_costs_the_fleet_nothing(tmp_path):
    token = secrets.token_urlsafe(16)
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    area = {"polygon": scenarios.rectangle(20, -10, 40, 60), "spacing_m": 10, "altitude_m": 15}
    spec = {"name": "stall", "area": area, "drones": list(DRONES)}
    with mosquitto(tmp_path) as broker:
        api = httpx.Client(base_url=url, headers={"Authorization": f"Bearer {token}"}, timeout=60)
        ground = ground_cmd(broker.full(), tmp_path, port, token)
        with (
            process(ground, tmp_path / "ground.log") as ground_proc,
            process(drone("STALL_1", broker.full()), tmp_path / "d1.log"),
            process(drone("STALL_2", broker.full()), tmp_path / "d2.log"),
        ):
            wait_http(url, timeout_s=120, log=tmp_path / "ground.log")
            for drone_id in DRONES:
                wait_online(api, drone_id, 120)
            time.sleep(3.0)  # the Identifier learns each drone's clock rate
            created = api.post("/api/v1/missions", params={"start": "true"}, json=spec)
            assert created.status_code == 201, created.text
            mission_id = created.json()["mission_id"]
            with busy_cores(), Watch(url, token) as watch:
                deadline = time.monotonic() + 60
                while api.get(f"/api/v1/missions/{mission_id}").json()["steps_done"] < 6:
                    assert time.monotonic() < deadline, "the mission did not get going"
                    time.sleep(0.2)
                os.kill(ground_proc.pid, signal.SIGSTOP)
                time.sleep(STALL_S)
                os.kill(ground_proc.pid, signal.SIGCONT)
                answered_s = first_answer_s(url, token)
                resumed = api.get(f"/api/v1/missions/{mission_id}").json()
                load, done = os.getloadavg()[0], f"{resumed['steps_done']} of {resumed['steps']}"
                print(
                    f"REST answered {answered_s:.3f} s after SIGCONT (load {load:.1f});"
                    f" mission {resumed['state']}, {done} steps"
                )
                deadline = time.monotonic() + 300
                while (detail := api.get(f"/api/v1/missions/{mission_id}").json())["state"] in (
                    "planned", "running", "handed_over", "stalled", "paused",
                ):  # fmt: skip
                    assert time.monotonic() < deadline, f"mission still {detail['state']}"
                    time.sleep(0.5)
                time.sleep(2.0)  # the watch sees the drones after the end too
        api.close()

    assert answered_s < 2.0, f"REST answered {answered_s:.2f} s after SIGCONT"
    flown_as_planned(detail)
    assert all(seen <= {"online"} for seen in watch.seen.values()), watch.seen
