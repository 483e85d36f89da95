"""The pre-flight checklist and the per-drone buttons over REST (issue 14).

Four simulated drones: CALM (as the demo's), WINDY (a 12 m/s westerly on its vehicle, as its
autopilot estimates it), FEWSATS (a GPS fix on 4 satellites) and LOW (30 % battery). A mission
on a drone that fails a check is refused with the checklist unless the operator overrides it
with a reason, which is audited; a step list out of order is refused with the step's index; one
drone of a mission is paused, resumed and aborted on its own; viewers may do none of it.
"""

from __future__ import annotations

import asyncio

import pytest

from dronefleet.drone.config import DroneConfig
from dronefleet.experiments.scenarios import rectangle
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.sim.wind import Wind
from dronefleet.simfleet import SimFleet
from support.ground_api import ground_clients

pytestmark = pytest.mark.integration
HOME = LLA(40.63, -8.659, 10.0)
DRONES = {"CALM": NED(0, 0), "WINDY": NED(0, 25), "FEWSATS": NED(25, 0), "LOW": NED(-25, 0)}


@pytest.fixture
async def fleet(embedded_broker):
    async with SimFleet(speedup=10) as fleet:
        for drone_id, offset in DRONES.items():
            extra: dict = {"wind": Wind.from_direction(12.0, 270.0)} if drone_id == "WINDY" else {}
            if drone_id == "LOW":
                extra["battery_pct"] = 30.0
            await fleet.add_drone(
                DroneConfig(drone_id=drone_id, heartbeat_interval_s=1.0),
                embedded_broker,
                home=ned_to_lla(offset, HOME),
                **extra,
            )
        fleet.world.vehicles["FEWSATS"].gps.satellites = 4
        yield fleet


@pytest.fixture
async def platform(embedded_broker, tmp_path, fleet):
    def ready(known: list[dict]) -> bool:  # every drone heard, with its gear
        return {d["drone_id"] for d in known if d.get("gps") and d.get("sensors")} == set(DRONES)

    async with ground_clients(
        embedded_broker, tmp_path, "preflight-test-planner", ready
    ) as clients:
        yield clients


def here(north: float, east: float) -> list[float]:
    p = ned_to_lla(NED(north, east), HOME)
    return [p.lat, p.lon]


def photo_steps(north: float = 20.0) -> list[dict]:
    lat, lon = here(north, 0)
    return [
        {"command": "navigate", "lat": lat, "lon": lon, "altitude_delta": 10},
        {"command": "wait_for_flight"},
        {"command": "takepic"},
    ]


def by_check(report: dict, drone_id: str) -> dict[str, dict]:
    (drone,) = [d for d in report["drones"] if d["drone_id"] == drone_id]
    return {c["check"]: c for c in drone["checks"]}


async def test_a_calm_drone_passes_every_check_and_says_why(platform):
    op, _ = platform
    fence = {"inclusion": rectangle(-40, -40, 120, 120), "ceiling_m": 50}
    spec = {"drones": ["CALM"], "steps": photo_steps(), "options": {"geofence": fence}}
    r = await op.post("/api/v1/missions/preflight", json=spec)
    assert r.status_code == 200, r.text
    report = r.json()
    assert report["ok"] and report["overridable"]
    checks = by_check(report, "CALM")
    assert list(checks) == ["battery", "gps", "link", "sensors", "fence", "wind"]
    assert {c["status"] for c in checks.values()} == {"pass"}, checks
    assert "3-D fix, 12 satellites" in checks["gps"]["reason"]
    assert "CAMERA" in checks["sensors"]["reason"]  # takepic needs the camera, and it is there
    assert checks["wind"]["reason"].startswith("0.0 m/s")  # the simulated world is calm here
    assert "ceiling 50 m" in checks["fence"]["reason"]
    assert "ends at" in checks["battery"]["reason"]


async def test_wind_and_gps_failures_block_the_start_unless_overridden_and_audited(platform):
    op, _ = platform
    for drone_id, check, words in [
        ("WINDY", "wind", "12.0 m/s from 270°, above 8.0 m/s"),
        ("FEWSATS", "gps", "on 4 satellites, fewer than 6"),
    ]:
        spec = {"name": f"pf-{drone_id}", "drones": [drone_id], "steps": photo_steps()}
        report = (await op.post("/api/v1/missions/preflight", json=spec)).json()
        assert not report["ok"] and report["overridable"]
        got = by_check(report, drone_id)[check]
        assert got["status"] == "fail" and words in got["reason"], got
        refused = await op.post("/api/v1/missions", params={"start": "true"}, json=spec)
        assert refused.status_code == 422, refused.text
        body = refused.json()
        assert body["detail"].startswith("pre-flight checks failed") and words in body["detail"]
        assert not body["preflight"]["ok"]
        assert (await op.get("/api/v1/missions")).json() == []  # nothing was created
    # A mission created to fly later is not checked until it starts.
    spec = {"name": "later", "drones": ["WINDY"], "steps": photo_steps()}
    planned = await op.post("/api/v1/missions", json=spec)
    assert planned.status_code == 201, planned.text
    mission_id = planned.json()["mission_id"]
    refused = await op.post(f"/api/v1/missions/{mission_id}/start")
    assert refused.status_code == 422 and "WINDY wind" in refused.json()["detail"]
    reason = "wind measured 4 m/s on site with a hand anemometer"
    started = await op.post(f"/api/v1/missions/{mission_id}/start", params={"override": reason})
    assert started.status_code == 200 and started.json()["state"] == "running", started.text
    audit = (await op.get("/api/v1/audit", params={"limit": 20})).json()
    (entry,) = [a for a in audit if a["command"] == "mission.preflight_override"]
    assert entry["params"]["reason"] == reason and entry["params"]["mission"] == mission_id
    assert any("WINDY wind" in f for f in entry["params"]["failed"]), entry
    assert any(a["command"] == "mission.start" and a["status"] == 422 for a in audit)
    await op.post(f"/api/v1/missions/{mission_id}/abort")
    # Created and started at once, with an override: flies too.
    spec = {"name": "now", "drones": ["FEWSATS"], "steps": photo_steps()}
    r = await op.post(
        "/api/v1/missions", params={"start": "true", "override": "RTK base"}, json=spec
    )
    assert r.status_code == 201 and r.json()["state"] == "running", r.text
    await op.post(f"/api/v1/missions/{r.json()['mission_id']}/abort")


async def test_a_share_the_planner_refuses_shows_as_a_failed_check_that_cannot_be_overridden(
    platform,
):
    op, _ = platform
    fence = {"inclusion": rectangle(-10, -10, 15, 15)}  # CALM's home in it, the waypoint not
    spec = {"drones": ["CALM"], "steps": photo_steps(40), "options": {"geofence": fence}}
    report = (await op.post("/api/v1/missions/preflight", json=spec)).json()
    assert not report["ok"] and not report["overridable"]
    checks = by_check(report, "CALM")
    assert checks["fence"]["status"] == "fail" and "outside the inclusion fence" in str(checks)
    assert checks["gps"]["status"] == "pass"  # the rest is still checked
    r = await op.post("/api/v1/missions", params={"start": "true", "override": "sure"}, json=spec)
    assert r.status_code == 422 and "fence" in r.json()["detail"]


@pytest.mark.parametrize(
    ("steps", "index", "words"),
    [
        (["arm", "takeoff", "land", "nav"], 3, "on the ground after the land at step 2"),
        (["arm", "takeoff", "rtl", "takepic"], 3, "after the rtl at step 2: take off again"),
        (["nav", "arm", "takeoff"], 0, "on the ground here: take off first"),
        (["takeoff", "nav"], 0, "not armed here: put an 'arm' step before"),
        (["arm", "takeoff", "nav", "disarm"], 3, "land it before disarming"),
    ],
)
async def test_a_step_list_out_of_order_is_refused_at_its_step(platform, steps, index, words):
    op, _ = platform
    lat, lon = here(15, 0)
    make = {
        "nav": {"command": "navigate", "lat": lat, "lon": lon, "altitude_delta": 10},
        "takeoff": {"command": "takeoff", "value": 10},
    }
    spec = {"drones": ["CALM"], "steps": [make.get(s, {"command": s}) for s in steps]}
    for path in ("/api/v1/missions/preview", "/api/v1/missions/preflight", "/api/v1/missions"):
        r = await op.post(path, json=spec)
        assert r.status_code == 422, (path, r.text)
        body = r.json()
        assert body["step_index"] == index and words in body["detail"], body
        assert body["detail"].startswith(
            f"step {index} ({steps[index].replace('nav', 'navigate')})"
        )
    assert (await op.get("/api/v1/missions")).json() == []


async def test_one_drone_is_paused_resumed_and_aborted_from_its_panel(platform):
    op, view = platform
    far = [
        {"command": "navigate", "lat": lat, "lon": lon, "altitude_delta": 10}
        for lat, lon in (here(60, 0), here(60, 60), here(0, 60))
    ]
    r = await op.post(
        "/api/v1/missions", params={"start": "true"}, json={"drones": ["CALM"], "steps": far}
    )
    assert r.status_code == 201, r.text
    mission_id = r.json()["mission_id"]
    for path in ("pause", "resume", "abort"):
        assert (await view.post(f"/api/v1/drones/CALM/{path}")).status_code == 403
    idle = await op.post("/api/v1/drones/WINDY/pause")
    assert idle.status_code == 409 and "flies no mission" in idle.json()["detail"]
    assert (await op.post("/api/v1/drones/CALM/resume")).status_code == 409  # not paused
    bad = await op.post("/api/v1/drones/CA LM/pause")
    assert bad.status_code == 422
    for _ in range(200):  # in the air
        if (await op.get("/api/v1/drones/CALM")).json()["state"] == "flying":
            break
        await asyncio.sleep(0.1)
    paused = await op.post("/api/v1/drones/CALM/pause")
    assert paused.status_code == 200 and paused.json()["mission_id"] == mission_id, paused.text
    for _ in range(100):
        got = (await op.get(f"/api/v1/missions/{mission_id}")).json()
        if got["state"] == "paused":
            break
        await asyncio.sleep(0.1)
    assert got["state"] == "paused" and "CALM" in got["error"], got
    resumed = await op.post("/api/v1/drones/CALM/resume")
    assert resumed.status_code == 200, resumed.text
    for _ in range(100):
        got = (await op.get(f"/api/v1/missions/{mission_id}")).json()
        if got["state"] == "running":
            break
        await asyncio.sleep(0.1)
    assert got["state"] == "running", got
    aborted = await op.post("/api/v1/drones/CALM/abort")  # its only drone: the mission ends
    assert aborted.status_code == 200, aborted.text
    assert aborted.json()["state"] == "stopped" and "home" in aborted.json()["error"]
    legs = (await op.get(f"/api/v1/missions/{mission_id}")).json()["legs"]
    assert legs[-1]["role"] == "recovery" and legs[-1]["prefix"][0]["command"] == "rtl"
    audit = (await op.get("/api/v1/audit", params={"limit": 50})).json()
    said = {(a["command"], a["status"]) for a in audit if a["drone_id"] == "CALM"}
    assert {("drone.pause", 200), ("drone.resume", 200), ("drone.resume", 409)} <= said
    assert ("drone.abort", 200) in said


async def test_aborting_one_drone_of_two_keeps_the_other_flying(platform):
    op, _ = platform
    area = {"polygon": rectangle(-10, 60, 60, 60), "spacing_m": 10, "altitude_m": 15}
    spec = {"drones": ["CALM", "FEWSATS"], "area": area}
    r = await op.post("/api/v1/missions", params={"start": "true", "override": "test"}, json=spec)
    assert r.status_code == 201, r.text
    mission_id = r.json()["mission_id"]
    aborted = await op.post("/api/v1/drones/CALM/abort")
    assert aborted.status_code == 200, aborted.text
    got = (await op.get(f"/api/v1/missions/{mission_id}")).json()
    assert got["state"] == "running" and "CALM aborted by the operator" in got["error"]
    by_drone = {leg["drone_id"]: leg for leg in got["legs"] if leg["role"] == "primary"}
    assert by_drone["CALM"]["state"] == "stopped" and by_drone["FEWSATS"]["state"] != "stopped"
    await op.post(f"/api/v1/missions/{mission_id}/abort")


async def test_the_preview_says_how_each_share_ends_and_explains_a_battery_below_reserve(
    platform,
):
    op, _ = platform
    spec = {"drones": ["CALM"], "steps": photo_steps(), "options": {"end_action": "land"}}
    body = (await op.post("/api/v1/missions/preview", json=spec)).json()
    assert body["end_action"] == "land" and body["drones"][0]["end"] == ["land", "wait_for_flight"]
    big = {"polygon": rectangle(-50, -50, 100, 100), "spacing_m": 10, "altitude_m": 20}
    r = await op.post("/api/v1/missions/preview", json={"drones": ["LOW"], "area": big})
    assert r.status_code == 200, r.text  # accepted: an idle drone will take over in flight
    body = r.json()
    (share,) = body["drones"]
    assert share["battery_end_pct"] < 20, share
    assert any("handed over in flight" in n and "takes over" in n for n in share["notes"]), share


async def test_bad_input_to_the_new_routes_is_a_422(platform):
    op, view = platform
    spec = {"drones": ["CALM"], "steps": photo_steps()}
    r = await op.post("/api/v1/missions", params={"start": "true", "override": "x"}, json=spec)
    assert r.status_code == 422 and "override" in r.json()["detail"]
    r = await op.post("/api/v1/missions/preflight", json={"drones": ["CALM"], "bogus": 1})
    assert r.status_code == 422
    assert (await view.post("/api/v1/missions/preflight", json=spec)).status_code == 403
    r = await op.post(
        "/api/v1/missions/preflight", json={"drones": ["NOPE"], "steps": photo_steps()}
    )
    assert r.status_code == 404
