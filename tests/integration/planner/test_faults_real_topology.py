"""Missions survive faults in the seed's real topology (issue 13, must-show 1).

Real processes, as in the issue's table: a ground Mosquitto; the drone's own Mosquitto bridged
to it with the configuration ``dronefleet bridge-config`` writes; ``dronefleet drone --fc sim``;
``dronefleet ground`` with its own state. A mission of eight waypoints is started over REST and,
once the drone is past its third waypoint, one part is killed with SIGKILL and started again
after an outage. Each row asserts what the issue asks: every waypoint reached, every step's
report at the planner, the mission ``completed``, its log whole.

Before this round the ground broker's row left the mission "running" forever with 125 of 172
reports lost, and the drone broker's row stopped the drone at 39 of 56 waypoints.
"""

from __future__ import annotations

import secrets
import subprocess
import time
from pathlib import Path

import httpx
import pytest

from dronefleet.messaging.embedded import free_port
from support.brokers import Mosquitto
from support.ground_procs import drone_cmd, ground_cmd, stop, wait_http, wait_online
from support.processes import dronefleet, process

pytestmark = pytest.mark.integration

SPEEDUP = 10
WAYPOINTS = 8
OUTAGE_WALL_S = 4.0  # 40 vehicle seconds
HOME = (40.63, -8.659)
ENDED = ("completed", "failed", "stopped")


def mission(drone_id: str) -> dict:
    steps: list[dict] = [{"command": "arm"}, {"command": "takeoff", "value": 10}]
    for i in range(WAYPOINTS):
        steps += [
            {"command": "navigate", "lat": HOME[0] + 0.00012 * (i + 1), "lon": HOME[1],
             "altitude_delta": 10},
            {"command": "wait_for_flight"},
        ]  # fmt: skip
    steps.append({"command": "land"})
    options = {"early_replacement": False, "collaboration": False, "replacement": False}
    return {"name": "fault", "drones": [drone_id], "steps": steps, "options": options}


def bridge(drone_id: str, ground_port: int) -> str:
    """The bridge section ``dronefleet bridge-config`` writes for the drone."""
    args = ["bridge-config", "--drone-id", drone_id, "--ground", f"127.0.0.1:{ground_port}"]
    return subprocess.run(dronefleet(*args), check=True, capture_output=True, text=True).stdout


def until(api: httpx.Client, mission_id: str, timeout_s: float, done: int | None = None) -> dict:
    """The mission once ``done`` steps are reported, or once it has ended (a mission whose
    drone is unheard for a while is ``stalled``, not ended: it runs again when it is back)."""
    deadline = time.monotonic() + timeout_s
    detail: dict = {}
    while time.monotonic() < deadline:
        answer = api.get(f"/api/v1/missions/{mission_id}")
        if answer.status_code == 200:
            detail = answer.json()
            if detail["state"] in ENDED or (done is not None and detail["steps_done"] >= done):
                return detail
        time.sleep(0.2)
    raise AssertionError(f"mission {mission_id} stuck: {detail}")


@pytest.mark.parametrize("fault", ["ground-broker", "drone-broker", "ground"])
def test_a_killed_part_comes_back_and_the_mission_completes_with_every_report(
    fault: str, tmp_path: Path
):
    drone_id = f"FAULT_{secrets.token_hex(3)}"
    token = secrets.token_urlsafe(16)
    http = free_port()
    ground_broker = Mosquitto(tmp_path)
    drone_broker = Mosquitto(tmp_path, extra_conf=bridge(drone_id, ground_broker.port))
    ground_broker.start()
    drone_broker.start()
    ground_log = tmp_path / "ground.log"
    ground_args = ground_cmd(ground_broker.url.full(), tmp_path, http, token)
    try:
        with (
            process(drone_cmd(drone_id, drone_broker.url.full(), SPEEDUP), tmp_path / "drone.log"),
            httpx.Client(
                base_url=f"http://127.0.0.1:{http}",
                headers={"Authorization": f"Bearer {token}"},
                timeout=30,
            ) as api,
        ):
            ground = process(ground_args, ground_log)
            ground_proc = ground.__enter__()
            try:
                wait_http(str(api.base_url), log=ground_log)
                wait_online(api, drone_id)
                created = api.post("/api/v1/missions", params={"start": "true"},
                                   json=mission(drone_id))  # fmt: skip
                assert created.status_code == 201, created.text
                mission_id = created.json()["mission_id"]
                before = until(api, mission_id, timeout_s=60, done=2 + 2 * 3)
                assert before["state"] == "running", before

                if fault == "ground-broker":
                    ground_broker.stop(kill=True)
                    time.sleep(OUTAGE_WALL_S)
                    ground_broker.start()
                elif fault == "drone-broker":
                    drone_broker.stop(kill=True)
                    time.sleep(OUTAGE_WALL_S)
                    drone_broker.start()
                else:  # the ground services themselves, with their state on disk
                    stop(ground_proc, sig_kill=True)
                    time.sleep(OUTAGE_WALL_S)
                    ground = process(ground_args, ground_log)
                    ground_proc = ground.__enter__()
                    wait_http(str(api.base_url), log=ground_log)

                after = until(api, mission_id, timeout_s=90)
                log = api.get(f"/api/v1/missions/{mission_id}/log")
            finally:
                ground.__exit__(None, None, None)
    finally:
        drone_broker.stop()
        ground_broker.stop()

    steps = len(mission(drone_id)["steps"])
    tail = ground_log.read_text()[-3000:]
    assert after["state"] == "completed", (after["state"], after["error"], tail)
    assert after["steps_done"] == steps and len(after["done"]) == steps
    assert after["waypoints_reached"] == after["waypoints"] == WAYPOINTS
    assert log.status_code == 200, log.text
    flown = [s for d in log.json()["drones"] for s in d["steps"]]
    assert sorted(s["index"] for s in flown) == list(range(steps)), flown
