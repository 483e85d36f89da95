"""PX4 as a supported autopilot (issue 28, item 7), on PX4 SITL (SIH quadrotor, b765769f50).

Before: every step mission paused at its own take-off ("taken over: flight mode AUTO.TAKEOFF set
by another ground station": PX4 acknowledges NAV_TAKEOFF before its HEARTBEAT shows the mode);
the ground showed HOLD while the drone flew to a target; an on-board mission was refused
(MAV_CMD_DO_SET_MISSION_CURRENT unsupported) and, past that, flew towards 0°N 0°E (take-off and
land items at lat/lon 0, 0); a photo step without a camera left the vehicle hovering; a killed
drone process left it flying on (NAV_DLL_ACT 0, PX4's default).
"""

from __future__ import annotations

import time

import pytest
from pymavlink import mavutil

from dronefleet.geo.ned import lla_to_ned, ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.protocols.mavlink.modes import Autopilot, mode_name
from support.processes import stop
from support.px4 import SPEED, OtherStation

pytestmark = [pytest.mark.integration, pytest.mark.px4]

ALT_M = 15.0


def home_of(drone: dict) -> LLA:
    h = drone["home"]
    return LLA(h["lat"], h["lon"], h["alt_m"])


def away_m(drone: dict, home: LLA) -> float:
    here = drone["position"]
    return lla_to_ned(LLA(here["lat"], here["lon"], home.alt_m), home).horizontal_m


def step_mission(home: LLA, legs: list[tuple[float, float]]) -> list[dict]:
    steps: list[dict] = []
    for n, e in legs:
        p = ned_to_lla(NED(n, e, 0), home)
        steps += [
            {"command": "navigate", "lat": p.lat, "lon": p.lon, "altitude_delta": ALT_M},
            {"command": "wait_for_flight"},
        ]
    return steps


def until(ground, drone_id: str, predicate, timeout_s: float, what: str) -> dict:
    deadline = time.monotonic() + timeout_s
    drone: dict = {}
    while time.monotonic() < deadline:
        drone = ground.drone(drone_id)
        if drone and predicate(drone):
            return drone
        time.sleep(0.25)
    raise AssertionError(f"{what}: not within {timeout_s} s; last {drone}")


def down_at_home(ground, drone_id: str, home: LLA) -> None:
    drone = until(ground, drone_id, lambda d: d["state"] == "disarmed", 90, "disarmed")
    assert away_m(drone, home) < 5.0, drone["position"]


def command(ground, drone_id: str, name: str, **body) -> None:
    answer = ground.api("POST", f"/api/v1/drones/{drone_id}/commands/{name}", json=body or None)
    assert answer.status_code == 200 and answer.json()["ok"], answer.text


def arm_and_take_off(ground, drone_id: str, alt_m: float) -> None:
    """Two REST commands, as an operator sends them. PX4 disarms a vehicle left on the ground
    armed for COM_DISARM_PRFLT (10 s of its time: 2.5 wall s at 4x): on a loaded host the
    take-off then answers "not armed; arm it first", and the operator arms again."""
    for _ in range(3):
        command(ground, drone_id, "arm")
        path = f"/api/v1/drones/{drone_id}/commands/takeoff"
        answer = ground.api("POST", path, json={"value": alt_m})
        if answer.status_code == 200 and answer.json()["ok"]:
            return
        assert "not armed" in answer.text, answer.text
    raise AssertionError(f"{drone_id} disarmed three times before its take-off")


def test_direct_commands_fly_and_the_ground_sees_the_target_flown(ground, fly):
    fly("PX4_1")
    home = home_of(ground.drone("PX4_1"))
    arm_and_take_off(ground, "PX4_1", ALT_M)
    until(ground, "PX4_1", lambda d: d["position"]["relative_alt_m"] > ALT_M - 1, 60, "climbed")
    there = ned_to_lla(NED(100, 0, 0), home)
    command(ground, "PX4_1", "navigate", lat=there.lat, lon=there.lon, altitude_delta=ALT_M)
    flying = until(ground, "PX4_1", lambda d: away_m(d, home) > 20, 30, "on its way")
    assert flying["mode"] == "GUIDED", flying["mode"]  # a target being flown, not HOLD
    arrived = until(ground, "PX4_1", lambda d: away_m(d, home) > 98, 60, "arrived")
    assert arrived["mode"] == "GUIDED"
    command(ground, "PX4_1", "rtl")
    down_at_home(ground, "PX4_1", home)


def test_a_companion_flown_step_mission_completes_with_the_default_end(ground, fly):
    fly("PX4_1")
    home = home_of(ground.drone("PX4_1"))
    spec = {
        "name": "step mission on PX4",
        "drones": ["PX4_1"],
        "steps": step_mission(home, [(40, 0), (40, 40)]),
    }
    mission = ground.run_mission(spec, timeout_s=150)
    assert mission["state"] == "completed", mission.get("error")
    assert mission["waypoints_reached"] == mission["waypoints"] == 2
    down_at_home(ground, "PX4_1", home)  # the planner's default end: RTL


def test_an_onboard_mission_flies_in_mission_mode(ground, fly):
    fly("PX4_1")
    home = home_of(ground.drone("PX4_1"))
    spec = {
        "name": "on board on PX4",
        "drones": ["PX4_1"],
        "steps": step_mission(home, [(40, 0), (40, 40)]),
        "options": {"onboard": True},
    }
    created = ground.api("POST", "/api/v1/missions?start=true", json=spec)
    assert created.status_code == 201, created.text
    mission_id = created.json()["mission_id"]
    flying = until(ground, "PX4_1", lambda d: away_m(d, home) > 10, 60, "on its way")
    assert flying["mode"] == "MISSION", flying["mode"]
    # Never towards 0°N 0°E: the take-off item is placed where the vehicle is.
    assert away_m(flying, home) < 70
    mission = ground.wait_ended(mission_id, timeout_s=150)
    assert mission["state"] == "completed", mission.get("error")
    record = ground.api("GET", f"/api/v1/missions/{mission_id}").json()
    assert record["legs"][0]["flown_by"] == "autopilot"
    down_at_home(ground, "PX4_1", home)


def taken_over(ground, vehicle, home: LLA, main: int, sub: int, **options) -> str:
    """A step mission started on PX4_1, then another station sets PX4 mode ``main``/``sub``
    once it is on its way; the mission's id, once the ground has paused it."""
    spec = {
        "name": "taken over on PX4",
        "drones": ["PX4_1"],
        "steps": step_mission(home, [(60, 0), (60, 40)]),
        **({"options": options} if options else {}),
    }
    created = ground.api("POST", "/api/v1/missions?start=true", json=spec)
    assert created.status_code == 201, created.text
    mission_id = created.json()["mission_id"]
    until(ground, "PX4_1", lambda d: away_m(d, home) > 20, 60, "on its way")
    other = OtherStation(vehicle)
    try:
        other.set_mode(main, sub)
    finally:
        other.close()
    deadline = time.monotonic() + 20
    mission = {}
    while time.monotonic() < deadline:
        mission = ground.api("GET", f"/api/v1/missions/{mission_id}").json()
        if mission["state"] == "paused":
            break
        time.sleep(0.5)
    assert mission["state"] == "paused", mission
    assert "taken over" in mission["error"], mission["error"]
    return mission_id


def test_another_stations_hold_pauses_the_mission_and_resume_flies_the_rest(ground, fly):
    vehicle = fly("PX4_1")
    home = home_of(ground.drone("PX4_1"))
    mission_id = taken_over(ground, vehicle, home, 4, 3, onboard=True)  # AUTO.LOITER: Hold
    mission = ground.api("GET", f"/api/v1/missions/{mission_id}").json()
    assert "AUTO.LOITER" in mission["error"], mission["error"]
    resumed = ground.api("POST", "/api/v1/drones/PX4_1/resume")
    assert resumed.status_code == 200, resumed.text
    mission = ground.wait_ended(mission_id, timeout_s=150)
    assert mission["state"] == "completed", mission.get("error")
    assert mission["waypoints_reached"] == mission["waypoints"] == 2
    down_at_home(ground, "PX4_1", home)


def test_a_companion_flown_area_mission_completes_with_the_default_end(ground, fly):
    fly("PX4_1")
    home = home_of(ground.drone("PX4_1"))
    corners = [ned_to_lla(NED(n, e, 0), home) for n, e in [(20, 0), (60, 0), (60, 30), (20, 30)]]
    spec = {
        "name": "area on PX4",
        "drones": ["PX4_1"],
        "area": {
            "polygon": [[c.lat, c.lon] for c in corners],
            "spacing_m": 15,
            "altitude_m": ALT_M,
        },
    }
    mission = ground.run_mission(spec, timeout_s=200)
    assert mission["state"] == "completed", mission.get("error")
    assert mission["waypoints_reached"] == mission["waypoints"] >= 4
    record = ground.api("GET", f"/api/v1/missions/{mission['mission_id']}").json()
    assert record["legs"][0].get("flown_by") != "autopilot"  # from the companion computer
    down_at_home(ground, "PX4_1", home)


def test_another_stations_rtl_pauses_the_mission_and_brings_the_vehicle_home(ground, fly):
    vehicle = fly("PX4_1")
    home = home_of(ground.drone("PX4_1"))
    mission_id = taken_over(ground, vehicle, home, 4, 5)  # AUTO.RTL: QGroundControl's Return
    mission = ground.api("GET", f"/api/v1/missions/{mission_id}").json()
    assert "AUTO.RTL" in mission["error"], mission["error"]
    down_at_home(ground, "PX4_1", home)  # the other station's RTL is flown, never undone


def test_a_failed_photo_step_sends_the_vehicle_home_not_hovering(ground, fly):
    """SIH has no camera: the photo step fails in the air (measured before: left hovering 40 m
    out, the mission failed). The drone flies the mission's end, the planner's default RTL."""
    fly("PX4_1")
    home = home_of(ground.drone("PX4_1"))
    steps = [*step_mission(home, [(40, 0)]), {"command": "takepic"}]
    spec = {"name": "photo without a camera", "drones": ["PX4_1"], "steps": steps}
    mission = ground.run_mission(spec, timeout_s=120)
    assert mission["state"] == "failed", mission
    assert "camera" in mission["error"] and "the mission's end: rtl" in mission["error"]
    down_at_home(ground, "PX4_1", home)


def test_a_killed_drones_px4_returns_home_and_a_live_one_never_fails_safe(ground, fly):
    """PX4's data link loss failsafe (NAV_DLL_ACT, COM_DL_LOSS_T as docs.px4.io defines them),
    checked and turned on at connect (drone/fc/mavlink/gcs_failsafe.py): the drone's heartbeats
    keep it off while it lives; killed, PX4 flies home by itself."""
    vehicle = fly("PX4_1")
    beat = ground.drone("PX4_1")
    failsafe = beat["link_failsafe"]
    assert failsafe["action"] == "rtl" and failsafe["timeout_s"] > 0, failsafe
    home = home_of(beat)
    arm_and_take_off(ground, "PX4_1", ALT_M)
    until(ground, "PX4_1", lambda d: d["position"]["relative_alt_m"] > ALT_M - 1, 60, "climbed")
    there = ned_to_lla(NED(40, 0, 0), home)
    command(ground, "PX4_1", "navigate", lat=there.lat, lon=there.lon, altitude_delta=ALT_M)
    until(ground, "PX4_1", lambda d: away_m(d, home) > 38, 60, "arrived")
    # Alive: longer than its timeout (PX4's rcS makes it 10 s x PX4_SIM_SPEED_FACTOR of
    # vehicle time), still GUIDED.
    time.sleep(1.25 * failsafe["timeout_s"] / SPEED)
    assert ground.drone("PX4_1")["mode"] == "GUIDED"

    assert vehicle.drone is not None
    stop(vehicle.drone, sig_kill=True)  # the drone software dies; PX4 hovers on
    killed_at = time.monotonic()
    watch = mavutil.mavlink_connection(vehicle.url, source_system=251)  # hears; never a GCS
    try:
        seen: list[str] = []
        boot_ms: list[int] = []  # PX4's own clock (lockstep: slower than SPEED x wall when busy)
        rtl_after_s = None
        while time.monotonic() - killed_at < 60 and rtl_after_s is None:
            msg = watch.recv_match(blocking=True, timeout=1)
            if msg is None or msg.get_srcSystem() != vehicle.system_id:
                continue
            if isinstance(getattr(msg, "time_boot_ms", None), int):
                boot_ms.append(msg.time_boot_ms)
            if msg.get_type() != "HEARTBEAT":
                continue
            seen.append(mode_name(Autopilot.PX4, msg.custom_mode))
            if seen[-1] == "AUTO.RTL" and boot_ms:
                rtl_after_s = (boot_ms[-1] - boot_ms[0]) / 1000.0
    finally:
        watch.close()
    print(f"PX4 AUTO.RTL {rtl_after_s} vehicle s after the kill; modes {set(seen)}")
    assert rtl_after_s is not None, (set(seen), vehicle.log()[-1500:])
    # COM_DL_LOSS_T, then PX4 holds COM_FAIL_ACT_T (5 s, the AUTO.LOITER seen) before acting.
    assert rtl_after_s < failsafe["timeout_s"] + 10
