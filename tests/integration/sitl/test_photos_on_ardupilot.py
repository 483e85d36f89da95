"""Photos are reported only when ArduPilot took them (issue 17, must-show 4).

Before: the trigger's COMMAND_ACK was not awaited, so SITL without a camera (CAM1_TYPE 0, which
answers FAILED) had 28 ``takepic`` steps reported as taken. Now a camera the autopilot does not
have is left out at start, and a trigger that fails still fails the step (simulator test in
tests/integration/mavlink/test_link_and_payload.py).
"""

from __future__ import annotations

import threading

import pytest
from pymavlink import mavutil

from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED

pytestmark = [pytest.mark.integration, pytest.mark.sitl]


def photo_mission(home: LLA, count: int) -> list[dict]:
    steps: list[dict] = []
    for i in range(count):
        p = ned_to_lla(NED(20.0 * (i + 1), 0, 0), home)
        steps += [
            {"command": "navigate", "lat": p.lat, "lon": p.lon, "altitude_delta": 15},
            {"command": "wait_for_flight"},
            {"command": "takepic"},
        ]
    return [*steps, {"command": "land"}, {"command": "wait_for_flight"}]


class FeedbackCounter:
    """A second ground station on SITL's SERIAL1 that counts CAMERA_FEEDBACK messages."""

    def __init__(self, instance: int) -> None:
        self.count = 0
        self._stop = threading.Event()
        self._conn = mavutil.mavlink_connection(
            f"tcp:127.0.0.1:{5762 + 10 * instance}", source_system=250
        )
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            self._conn.mav.heartbeat_send(6, 8, 0, 0, 0)  # a GCS, so SITL talks to this link
            msg = self._conn.recv_match(type="CAMERA_FEEDBACK", blocking=True, timeout=0.5)
            if msg is not None:
                self.count += 1

    def close(self) -> None:
        self._stop.set()
        self._thread.join(5)
        self._conn.close()


def test_a_photo_step_without_a_camera_fails_with_the_reason(ground, fly):
    fly("SITL_1")
    home = ground.drone("SITL_1")["home"]
    spec = {
        "name": "photos, no camera",
        "drones": ["SITL_1"],
        "steps": photo_mission(LLA(home["lat"], home["lon"], home["alt_m"]), 1),
        "options": {"strategy": "seed"},
    }
    mission = ground.run_mission(spec)
    assert mission["state"] == "failed"
    assert "has no camera" in mission["error"]  # CAM1_TYPE 0: known at start, as for CO2


def test_with_a_camera_every_reported_photo_is_one_ardupilot_took(ground, fly):
    vehicle = fly("SITL_1", params={"CAM1_TYPE": 1})  # a servo-triggered camera
    counter = FeedbackCounter(vehicle.instance)
    try:
        home = ground.drone("SITL_1")["home"]
        spec = {
            "name": "photos",
            "drones": ["SITL_1"],
            "steps": photo_mission(LLA(home["lat"], home["lon"], home["alt_m"]), 3),
            "options": {"strategy": "seed"},
        }
        mission = ground.run_mission(spec)
    finally:
        counter.close()
    assert mission["state"] == "completed", mission.get("error")
    log = ground.api("GET", f"/api/v1/missions/{mission['mission_id']}/log").json()
    photos = [
        s
        for d in log["drones"]
        for s in d["steps"]
        if s["index"] is not None and log["work"][s["index"]]["command"] == "takepic"
    ]
    assert len(photos) == 3
    assert counter.count == 3


def test_an_area_with_photos_is_flown_and_every_photo_is_one_ardupilot_took(ground, fly):
    vehicle = fly("SITL_1", params={"CAM1_TYPE": 1})
    counter = FeedbackCounter(vehicle.instance)
    try:
        h = ground.drone("SITL_1")["home"]
        home = LLA(h["lat"], h["lon"], h["alt_m"])
        corners = [
            ned_to_lla(NED(n, e, 0), home) for n, e in [(20, 0), (100, 0), (100, 120), (20, 120)]
        ]
        spec = {
            "name": "area with photos",
            "drones": ["SITL_1"],
            "area": {
                "polygon": [[c.lat, c.lon] for c in corners],
                "spacing_m": 20,
                "altitude_m": 20,
                "action": "takepic",
            },
        }
        mission = ground.run_mission(spec, timeout_s=300)
    finally:
        counter.close()
    assert mission["state"] == "completed", mission.get("error")
    assert mission["waypoints_reached"] == mission["waypoints"]
    photos = sum(1 for s in mission["work"] if s["command"] == "takepic")
    assert photos > 0 and counter.count == photos
