"""Missions made by the planner fly on ArduPilot Copter SITL, through the REST API (issue 17).

Before: the planner's default step mission never left the ground (a GUIDED target sent 0.01 s
after NAV_TAKEOFF replaced the take-off with a waypoint, and DISARM_DELAY disarmed the copter),
and a two-vehicle split left both on the ground.
"""

from __future__ import annotations

import time

import pytest

from dronefleet.geo.ned import lla_to_ned, ned_to_lla
from dronefleet.geo.types import LLA, NED

pytestmark = [pytest.mark.integration, pytest.mark.sitl]

ALT_M = 20.0


def home_of(drone: dict) -> LLA:
    h = drone["home"]
    return LLA(h["lat"], h["lon"], h["alt_m"])


def step_mission(home: LLA, legs: list[tuple[float, float]]) -> list[dict]:
    """Waypoints at ALT_M; the planner ends them as it ends every mission (home by RTL, its
    default: issue 28 — these tests once ended with a land of their own, and so never saw
    the default end)."""
    steps: list[dict] = []
    for n, e in legs:
        p = ned_to_lla(NED(n, e, 0), home)
        steps += [
            {"command": "navigate", "lat": p.lat, "lon": p.lon, "altitude_delta": ALT_M},
            {"command": "wait_for_flight"},
        ]
    return steps


def highest_m(ground, mission_id: str) -> dict[str, float]:
    log = ground.api("GET", f"/api/v1/missions/{mission_id}/log").json()
    return {
        d["drone_id"]: max((p.get("alt") or 0.0) for p in d["path"] or [{}])  # m above home
        for d in log["drones"]
    }


@pytest.mark.parametrize("strategy", ["ours", "seed"])
def test_the_planners_step_mission_takes_off_and_completes(ground, fly, strategy):
    fly("SITL_1")
    home = home_of(ground.drone("SITL_1"))
    spec = {
        "name": f"step mission ({strategy})",
        "drones": ["SITL_1"],
        "steps": step_mission(home, [(100, 0), (100, 100), (0, 100), (0, 0), (50, 50)]),
        "options": {"strategy": strategy},
    }
    mission = ground.run_mission(spec)
    assert mission["state"] == "completed", mission.get("error")
    assert mission["waypoints_reached"] == mission["waypoints"] == 5
    assert highest_m(ground, mission["mission_id"])["SITL_1"] > ALT_M - 2
    drone = ground.drone("SITL_1")  # home and down (the default end), disarmed by ArduPilot
    assert drone["state"] == "disarmed", drone["state"]
    here = drone["position"]
    assert lla_to_ned(LLA(here["lat"], here["lon"], home.alt_m), home).horizontal_m < 5.0


def test_an_area_split_over_two_vehicles_flies_with_both_airborne(ground, fly):
    fly("SITL_1")
    fly("SITL_2")
    home = home_of(ground.drone("SITL_1"))
    corners = [ned_to_lla(NED(n, e, 0), home) for n, e in [(20, 0), (100, 0), (100, 60), (20, 60)]]
    spec = {
        "name": "split",
        "drones": ["SITL_1", "SITL_2"],
        "area": {
            "polygon": [[c.lat, c.lon] for c in corners],
            "spacing_m": 20,
            "altitude_m": ALT_M,
        },
    }
    mission = ground.run_mission(spec, timeout_s=300)
    assert mission["state"] == "completed", mission.get("error")
    assert mission["waypoints_reached"] == mission["waypoints"]
    heights = highest_m(ground, mission["mission_id"])
    assert set(heights) == {"SITL_1", "SITL_2"}
    assert all(h > ALT_M - 2 for h in heights.values()), heights


def test_an_onboard_step_mission_is_started_and_flown_by_ardupilot(ground, fly):
    # Before: MISSION_START carried a first item, which Copter denies (GCS_MAVLink_Copter.cpp);
    # and (issue 28) the default end, rtl, had no on-board form: the mission silently flew from
    # the companion computer. Now it flies in AUTO to the end, NAV_RETURN_TO_LAUNCH included.
    fly("SITL_1")
    home = home_of(ground.drone("SITL_1"))
    spec = {
        "name": "on board",
        "drones": ["SITL_1"],
        "steps": step_mission(home, [(100, 0), (100, 100), (0, 100)]),
        "options": {"onboard": True},
    }
    mission = ground.run_mission(spec)
    assert mission["state"] == "completed", mission.get("error")
    assert mission["waypoints_reached"] == mission["waypoints"] == 3
    assert highest_m(ground, mission["mission_id"])["SITL_1"] > ALT_M - 2
    record = ground.api("GET", f"/api/v1/missions/{mission['mission_id']}").json()
    assert record["legs"][0]["flown_by"] == "autopilot"
    drone = ground.drone("SITL_1")
    assert drone["state"] == "disarmed", drone["state"]
    here = drone["position"]
    assert lla_to_ned(LLA(here["lat"], here["lon"], home.alt_m), home).horizontal_m < 5.0


def test_an_operator_rtl_brings_the_copter_home_and_down(ground, fly):
    fly("SITL_1")
    home = home_of(ground.drone("SITL_1"))
    spec = {
        "name": "far away",
        "drones": ["SITL_1"],
        "steps": step_mission(home, [(150, 0), (150, 150)]),
    }
    created = ground.api("POST", "/api/v1/missions?start=true", json=spec)
    assert created.status_code == 201, created.text
    mission_id = created.json()["mission_id"]
    for _ in range(120):  # until it is well on its way
        drone = ground.drone("SITL_1")
        if (drone.get("position") or {}).get("relative_alt_m", 0) > 10 and drone["step_index"]:
            break
        time.sleep(0.5)
    assert ground.api("POST", f"/api/v1/missions/{mission_id}/stop").status_code == 200
    answer = ground.api("POST", "/api/v1/drones/SITL_1/commands/rtl")
    assert answer.status_code == 200, answer.text
    for _ in range(240):
        drone = ground.drone("SITL_1")
        if drone.get("state") == "disarmed":
            break
        time.sleep(0.5)
    assert drone["state"] == "disarmed" and drone["mode"] == "RTL"
    here = drone["position"]
    away = lla_to_ned(LLA(here["lat"], here["lon"], home.alt_m), home)
    assert away.horizontal_m < 5.0 and here["relative_alt_m"] < 1.0


def test_a_second_flight_is_estimated_from_the_draw_measured_on_the_first(ground, fly):
    """Must-show 3 (issue 17): ±10 % of flown time and ±5 points of battery. The first flight of a
    vehicle is estimated with the dissertation quad's draw (18 A; SITL draws about 30 A); the
    drone measures what it drew and the next estimate uses it."""
    vehicle = fly("SITL_1")
    home = home_of(ground.drone("SITL_1"))
    spec = {
        "name": "twice",
        "drones": ["SITL_1"],
        "steps": step_mission(home, [(100, 0), (100, 100), (0, 100), (0, 0)]),
    }
    first = ground.run_mission(spec)
    assert first["state"] == "completed", first.get("error")
    measured = ground.drone("SITL_1")["flight"]["flight_current_a"]
    assert 20 < measured < 45  # SITL's quad, not the dissertation's 18 A
    vehicle.swap_battery()
    deadline = time.monotonic() + 30
    while ground.drone("SITL_1")["battery"]["remaining_pct"] < 99:
        assert time.monotonic() < deadline, "the fresh battery never showed"
        time.sleep(0.5)
    preview = ground.api("POST", "/api/v1/missions/preview", json=spec).json()["drones"][0]
    second = ground.run_mission(spec)
    assert second["state"] == "completed", second.get("error")
    record = ground.api("GET", f"/api/v1/missions/{second['mission_id']}").json()
    (leg,) = record["legs"]
    flown_s = leg["ended_vehicle_s"] - leg["started_vehicle_s"]
    used_pct = 100 - ground.drone("SITL_1")["battery"]["remaining_pct"]
    assert preview["duration_s"] == pytest.approx(flown_s, rel=0.10)
    assert preview["battery_used_pct"] == pytest.approx(used_pct, abs=5)
