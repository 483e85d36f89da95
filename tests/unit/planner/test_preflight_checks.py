"""Each pre-flight check, from what the Drone Identifier publishes about a drone (issue 14)."""

from __future__ import annotations

import pytest

from dronefleet.ground.planner import preflight
from dronefleet.ground.planner.preflight import CheckStatus
from dronefleet.messaging.fence import Geofence

HOME = {"lat": 40.63, "lon": -8.659, "alt_m": 10.0}


def drone(**fields) -> dict:
    base = {
        "drone_id": "Q",
        "status": "online",
        "seen_ago_s": 1.0,
        "heartbeat_interval_s": 5.0,
        "position": HOME,
        "home": HOME,
        "battery": {"remaining_pct": 90.0},
        "state": "disarmed",
        "gps": {"fix": "3d", "satellites": 12, "hdop": 0.8},
        "wind": {"speed_mps": 3.0, "from_deg": 270.0},
        "flight": {"speed_mps": 10.0},
        "sensors": {"GAS": {"CO2": "SCD30"}, "CAMERA": "GoPro"},
    }
    return {**base, **fields}


@pytest.mark.parametrize(
    ("record", "status", "words"),
    [
        (drone(), "pass", "3-D fix, 12 satellites, HDOP 0.8"),
        (drone(gps={"fix": "2d", "satellites": 9}), "fail", "no 3-D fix (fix: 2d)"),
        (drone(gps={"fix": "3d", "satellites": 5}), "fail", "on 5 satellites, fewer than 6"),
        (drone(gps=None), "unknown", "reports no GPS status"),
    ],
)
def test_gps(record, status, words):
    got = preflight.gps(record)
    assert got.status == status and words in got.reason


@pytest.mark.parametrize(
    ("record", "status", "words"),
    [
        (drone(), "pass", "3.0 m/s from 270° (limit 8.0 m/s)"),
        (drone(wind={"speed_mps": 8.5, "from_deg": 90}), "fail", "above 8.0 m/s (80% of its 10"),
        (drone(wind={"speed_mps": 8.5, "from_deg": 90}, flight={"speed_mps": 15}), "pass", "12.0"),
        (drone(wind=None), "unknown", "reports no wind estimate"),  # never guessed
    ],
)
def test_wind(record, status, words):
    got = preflight.wind(record)
    assert got.status == status and words in got.reason


@pytest.mark.parametrize(
    ("record", "status", "words"),
    [
        (drone(), "pass", "last heartbeat 1.0 s ago (one every 5.0 s)"),
        # The wall clock alone fails nobody: a ground stalled by a busy host reads heartbeats
        # late; the Identifier's awake-time verdict ("lost") is the rule.
        (drone(seen_ago_s=16.0), "pass", "last heartbeat 16.0 s ago"),
        (
            drone(status="lost", seen_ago_s=30.0, lost_after_s=15.0),
            "fail",
            "30 s ago (lost after 15.0 s)",
        ),
        (drone(status="autopilot link lost"), "fail", "cannot reach its autopilot"),
    ],
)
def test_link(record, status, words):
    got = preflight.link(record)
    assert got.status == status and words in got.reason


@pytest.mark.parametrize(
    ("record", "commands", "status", "words"),
    [
        (drone(), {"navigate"}, "pass", "uses no sensor or camera"),
        (drone(), {"takepic", "read_sensors"}, "pass", "on board: CAMERA, GAS"),
        (drone(sensors={"CAMERA": "GoPro"}), {"read_sensors"}, "fail", "needs a sensor"),
        (drone(sensors={"GAS": {}}), {"camera_trigger"}, "fail", "needs a camera"),
        (drone(sensors=None), {"takepic"}, "unknown", "not known yet"),
    ],
)
def test_sensors(record, commands, status, words):
    got = preflight.sensors(record, commands)
    assert got.status == status and words in got.reason


def test_fence_the_drone_must_start_inside():
    lat, lon = HOME["lat"], HOME["lon"]
    around = Geofence(inclusion=[[lat - 1e-3, lon - 1e-3], [lat - 1e-3, lon + 1e-3],
                                 [lat + 1e-3, lon + 1e-3], [lat + 1e-3, lon - 1e-3]])  # fmt: skip
    assert preflight.fence(drone(), around).status == CheckStatus.PASS
    away = drone(position={**HOME, "lat": lat + 0.01}, home={**HOME, "lat": lat + 0.01})
    got = preflight.fence(away, around)
    assert (
        got.status == CheckStatus.FAIL
        and "its position is outside the inclusion fence" in got.reason
    )


def test_battery_says_what_the_share_needs_and_what_happens_below_the_reserve():
    fine = {"battery_used_pct": 30.0, "battery_end_pct": 60.0, "duration_s": 300.0}
    assert "needs 30 % for 300 s, has 90 %: ends at 60 %" in preflight.battery(fine, 20).reason
    short = {"battery_used_pct": 40.0, "battery_end_pct": -10.0, "duration_s": 400.0}
    got = preflight.battery(short, 20)
    assert got.status == CheckStatus.PASS and "takes over in flight" in got.reason
