"""The Mission Planner over REST: preview, refusals with reasons, create, start, stop, log, call.

Missions above the altitude limit, or that a drone's battery cannot finish, are refused with the
reason and nothing changes; viewers cannot command.
"""

from __future__ import annotations

import asyncio

import httpx
import pytest

from dronefleet.drone.config import DroneConfig
from dronefleet.experiments.scenarios import rectangle
from dronefleet.geo.ned import lla_to_ned, ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.simfleet import SimFleet
from support.ground_api import ground_clients, heard

pytestmark = pytest.mark.integration
HOME = LLA(40.63, -8.659, 10.0)


@pytest.fixture
async def fleet(embedded_broker):
    async with SimFleet(speedup=10) as fleet:
        await fleet.add_drone(DroneConfig(drone_id="FULL"), embedded_broker, home=HOME)
        low_home = ned_to_lla(NED(0, 20), HOME)
        await fleet.add_drone(
            DroneConfig(drone_id="LOW"), embedded_broker, home=low_home, battery_pct=24.0
        )
        yield fleet


@pytest.fixture
async def platform(embedded_broker, tmp_path, fleet):
    ready = heard("FULL", "LOW")
    async with ground_clients(embedded_broker, tmp_path, "api-test-planner", ready) as clients:
        yield clients


def area(**extra) -> dict:
    return {"polygon": rectangle(20, 0, 30, 40), "spacing_m": 10, "altitude_m": 15, **extra}


def fenced(**fence) -> dict:
    return {"drones": ["FULL"], "area": area(), "options": {"geofence": fence}}


async def test_a_mission_inside_its_fence_is_accepted(platform):
    op, _ = platform
    spec = fenced(inclusion=rectangle(-10, -30, 80, 80), exclusions=[rectangle(70, 0, 10, 10)])
    r = await op.post("/api/v1/missions/preview", json=spec)
    assert r.status_code == 200, r.text


async def until_state(op: httpx.AsyncClient, mission_id: str, states: set[str], timeout_s=90):
    for _ in range(int(timeout_s / 0.2)):
        got = (await op.get(f"/api/v1/missions/{mission_id}")).json()
        if got["state"] in states:
            return got
        await asyncio.sleep(0.2)
    raise AssertionError(f"mission {mission_id} still {got['state']}")


async def test_preview_gives_waypoints_time_and_battery(platform):
    op, _ = platform
    r = await op.post("/api/v1/missions/preview", json={"drones": ["FULL"], "area": area()})
    assert r.status_code == 200, r.text
    body = r.json()
    assert len(body["waypoints"]) >= 12
    (share,) = body["drones"]
    assert share["drone_id"] == "FULL" and share["duration_s"] > 30
    assert 0 < share["battery_used_pct"] < 20
    # One drone flies the whole area: its route is every waypoint, in the order flown.
    assert share["waypoints"] == body["waypoints"]


@pytest.mark.parametrize(
    ("spec", "status", "reason"),
    [
        ({"drones": ["FULL"], "area": area(altitude_m=150)}, 422, "above the 120 m limit"),
        ({"drones": ["FULL"], "steps": [{"command": "takeoff", "value": 300}]}, 422, "120 m limit"),
        ({"drones": ["NOPE"], "area": area()}, 404, "not known"),
        ({"drones": ["FULL"]}, 422, "give 'steps', 'area', or both"),
        ({"drones": ["FULL"], "steps": [{"command": "warp"}]}, 422, "step 0"),
        ({"drones": ["FULL"], "area": {"polygon": [[1, 2]], "spacing_m": 5}}, 422, "polygon"),
        (fenced(inclusion=rectangle(-10, -10, 60, 45)), 422, "outside the inclusion fence"),
        (fenced(exclusions=[rectangle(35, -20, 80, 10)]), 422, "exclusion zone 1"),
        (fenced(ceiling_m=10), 422, "above the fence ceiling of 10 m"),
        (fenced(ceiling_m=-1), 422, "ceiling_m"),
    ],
)
async def test_bad_missions_are_refused_with_the_reason(platform, spec, status, reason):
    op, _ = platform
    r = await op.post("/api/v1/missions", json=spec)
    assert r.status_code == status, r.text
    assert reason in r.text
    assert (await op.get("/api/v1/missions")).json() == []  # nothing was created


async def test_a_mission_the_battery_cannot_finish_is_refused(platform):
    op, _ = platform
    big = {"polygon": rectangle(0, 0, 200, 300), "spacing_m": 5, "altitude_m": 20}
    r = await op.post("/api/v1/missions", json={"drones": ["LOW"], "area": big})
    assert r.status_code == 422 and "cannot finish" in r.json()["detail"]


async def test_viewers_see_but_cannot_command(platform):
    _op, view = platform
    assert (await view.get("/api/v1/missions")).status_code == 200
    r = await view.post("/api/v1/missions", json={"drones": ["FULL"], "area": area()})
    assert r.status_code == 403


async def test_a_mission_is_created_flown_logged_and_listed(platform):
    op, _ = platform
    r = await op.post(
        "/api/v1/missions",
        params={"start": "true"},
        json={"name": "api", "drones": ["FULL"], "area": area(action="takepic")},
    )
    assert r.status_code == 201, r.text
    mission_id = r.json()["mission_id"]
    done = await until_state(op, mission_id, {"completed", "failed"})
    assert done["state"] == "completed", done
    assert done["waypoints_reached"] == done["waypoints"] > 0
    log = (await op.get(f"/api/v1/missions/{mission_id}/log")).json()
    (drone,) = log["drones"]
    assert drone["drone_id"] == "FULL" and len(drone["path"]) > 5
    photos = sum(1 for s in done["work"] if s["command"] == "takepic")  # one a cell
    assert 0 < photos < done["waypoints"]  # the swaths' ends are passed, not photographed
    assert sum(1 for s in drone["steps"] if s["command"] == "takepic") == photos
    listed = (await op.get("/api/v1/missions")).json()
    assert [m["mission_id"] for m in listed] == [mission_id]


async def test_a_mission_created_without_starting_starts_later(platform):
    # It answered 500: the record's options carried a key its model forbids (issue 11).
    op, _ = platform
    r = await op.post("/api/v1/missions", json={"drones": ["FULL"], "area": area()})
    assert r.status_code == 201, r.text
    mission_id = r.json()["mission_id"]
    assert r.json()["state"] == "planned"
    started = await op.post(f"/api/v1/missions/{mission_id}/start")
    assert started.status_code == 200, started.text
    assert started.json()["state"] == "running"
    done = await until_state(op, mission_id, {"completed", "failed"})
    assert done["state"] == "completed", done


async def test_stopping_a_mission_and_calling_a_drone(platform):
    op, _ = platform
    r = await op.post(
        "/api/v1/missions", params={"start": "true"}, json={"drones": ["FULL"], "area": area()}
    )
    mission_id = r.json()["mission_id"]
    await asyncio.sleep(1.0)
    stopped = (await op.post(f"/api/v1/missions/{mission_id}/stop")).json()
    assert stopped["state"] == "stopped"
    assert (await op.post(f"/api/v1/missions/{mission_id}/start")).status_code == 409
    here = ned_to_lla(NED(30, 30), HOME)
    for _ in range(50):  # the Identifier learns that FULL is idle again from its heartbeats
        call = await op.post("/api/v1/call", json={"lat": here.lat, "lon": here.lon})
        if call.status_code == 201:
            break
        await asyncio.sleep(0.2)
    assert call.status_code == 201, call.text
    arrived = await until_state(op, call.json()["mission_id"], {"completed", "failed"})
    assert arrived["state"] == "completed"
    bad = await op.post("/api/v1/call", json={"lat": 95, "lon": 0})
    assert bad.status_code == 422


async def test_aborting_a_mission_brings_its_drone_home(platform):
    """Issue 14: abort stops the mission and sends its drones home (RTL), where they land."""
    op, view = platform
    r = await op.post(
        "/api/v1/missions", params={"start": "true"}, json={"drones": ["FULL"], "area": area()}
    )
    mission_id = r.json()["mission_id"]
    await until_state(op, mission_id, {"running"})
    for _ in range(100):  # out in the field, away from home
        drone = (await op.get("/api/v1/drones/FULL")).json()
        if drone["state"] == "flying":
            break
        await asyncio.sleep(0.1)
    await asyncio.sleep(2.0)
    assert (await view.post(f"/api/v1/missions/{mission_id}/abort")).status_code == 403
    aborted = await op.post(f"/api/v1/missions/{mission_id}/abort")
    assert aborted.status_code == 200, aborted.text
    assert aborted.json()["state"] == "stopped" and "home" in aborted.json()["error"]
    for _ in range(300):
        drone = (await op.get("/api/v1/drones/FULL")).json()
        if drone["state"] in ("disarmed", "armed"):  # on the ground again
            break
        await asyncio.sleep(0.1)
    here = drone["position"]
    offset = lla_to_ned(LLA(here["lat"], here["lon"], HOME.alt_m), HOME)
    assert drone["state"] in ("disarmed", "armed") and abs(offset.n) < 3 and abs(offset.e) < 3, (
        drone
    )


async def test_a_drone_taken_over_pauses_its_mission_until_resumed_over_rest(platform, fleet):
    op, view = platform
    r = await op.post(
        "/api/v1/missions", params={"start": "true"}, json={"drones": ["FULL"], "area": area()}
    )
    mission_id = r.json()["mission_id"]
    got = await until_state(op, mission_id, {"running"})
    for _ in range(300):  # a few waypoints flown
        got = (await op.get(f"/api/v1/missions/{mission_id}")).json()
        if got["steps_done"] >= 3:
            break
        await asyncio.sleep(0.1)
    refused = await op.post(f"/api/v1/missions/{mission_id}/resume")
    assert refused.status_code == 409 and "not paused" in refused.text
    fleet.world.vehicles["FULL"].hold()  # an RC pilot's mode switch
    paused = await until_state(op, mission_id, {"paused"}, timeout_s=20)
    assert "FULL" in paused["error"] and "taken over" in paused["error"]
    assert (await view.post(f"/api/v1/missions/{mission_id}/resume")).status_code == 403
    resumed = await op.post(f"/api/v1/missions/{mission_id}/resume")
    assert resumed.status_code == 200, resumed.text
    done = await until_state(op, mission_id, {"completed", "failed", "stopped"}, timeout_s=120)
    assert done["state"] == "completed", done
    assert done["steps_done"] == done["steps"]


async def test_an_operator_pauses_a_mission_its_drone_holds_and_resume_finishes_it(platform):
    op, view = platform
    r = await op.post(
        "/api/v1/missions", params={"start": "true"}, json={"drones": ["FULL"], "area": area()}
    )
    mission_id = r.json()["mission_id"]
    await until_state(op, mission_id, {"running"})
    for _ in range(300):
        got = (await op.get(f"/api/v1/missions/{mission_id}")).json()
        if got["steps_done"] >= 3:
            break
        await asyncio.sleep(0.1)
    assert (await view.post(f"/api/v1/missions/{mission_id}/pause")).status_code == 403
    asked = await op.post(f"/api/v1/missions/{mission_id}/pause")
    assert asked.status_code == 200, asked.text
    paused = await until_state(op, mission_id, {"paused"}, timeout_s=20)
    assert "paused by the operator" in paused["error"]
    again = await op.post(f"/api/v1/missions/{mission_id}/pause")
    assert again.status_code == 409 and "nothing to pause" in again.text
    held = (await op.get(f"/api/v1/missions/{mission_id}")).json()["steps_done"]
    await asyncio.sleep(2.0)  # 20 vehicle seconds: it holds
    assert (await op.get(f"/api/v1/missions/{mission_id}")).json()["steps_done"] == held
    assert (await op.post(f"/api/v1/missions/{mission_id}/resume")).status_code == 200
    done = await until_state(op, mission_id, {"completed", "failed", "stopped"}, timeout_s=120)
    assert done["state"] == "completed" and done["steps_done"] == done["steps"], done


async def test_abort_all_stops_every_unfinished_mission_and_sends_its_drones_home(platform):
    op, view = platform
    r = await op.post(
        "/api/v1/missions", params={"start": "true"}, json={"drones": ["FULL"], "area": area()}
    )
    mission_id = r.json()["mission_id"]
    await until_state(op, mission_id, {"running"})
    assert (await view.post("/api/v1/missions/abort")).status_code == 403
    aborted = await op.post("/api/v1/missions/abort")
    assert aborted.status_code == 200, aborted.text
    assert [(m["mission_id"], m["state"]) for m in aborted.json()] == [(mission_id, "stopped")]
    assert (await op.post("/api/v1/missions/abort")).json() == []  # nothing left to abort
