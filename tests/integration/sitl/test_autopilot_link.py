"""A companion computer outlives its autopilot link (issue 17, must-show 5).

Before: a drone process whose autopilot vanished at start exited after 15 s, and the planner
then called the drone lost.
"""

from __future__ import annotations

import time

import pytest

pytestmark = [pytest.mark.integration, pytest.mark.sitl]


def wait_status(ground, drone_id: str, status: str, timeout_s: float = 60) -> dict:
    deadline = time.monotonic() + timeout_s
    drone: dict = {}
    while time.monotonic() < deadline:
        drone = ground.drone(drone_id)
        if drone.get("status") == status:
            return drone
        time.sleep(0.25)
    raise AssertionError(f"{drone_id} never {status!r}; last: {drone.get('status')!r}")


def test_sitl_killed_in_flight_is_shown_as_a_lost_link_and_found_again(ground, fly, tmp_path):
    vehicle = fly("SITL_1")
    answer = ground.api("POST", "/api/v1/drones/SITL_1/commands/arm")
    assert answer.status_code == 200, answer.text
    answer = ground.api("POST", "/api/v1/drones/SITL_1/commands/takeoff", json={"value": 10})
    assert answer.status_code == 200, answer.text
    for _ in range(60):
        if ground.drone("SITL_1")["position"]["relative_alt_m"] > 5:
            break
        time.sleep(0.25)

    vehicle.kill()  # the autopilot vanishes mid-flight
    lost = wait_status(ground, "SITL_1", "autopilot link lost")
    assert lost["seen_ago_s"] < 5  # the drone itself still beats: not "lost"
    drone_log = (tmp_path / "SITL_1.log").read_text()
    assert "Traceback" not in drone_log

    vehicle.restart()  # the autopilot is back (on the ground: SITL starts afresh)
    back = wait_status(ground, "SITL_1", "online", timeout_s=90)
    assert back["vehicle_time_s"] is not None
