"""Mission files over REST (issue 14): a QGroundControl .plan and a Google Earth KML imported into
what the planner takes, a mission exported as .plan, and bad files refused with the reason.

A real ground (REST on a real port, planning worker process) and a simulated drone; the files are
the hand-written ones of tests/support/mission_files, in QGroundControl's and Google Earth's
formats.
"""

from __future__ import annotations

import json
from pathlib import Path

import httpx
import pytest

from dronefleet.drone.config import DroneConfig
from dronefleet.geo.types import LLA
from dronefleet.simfleet import SimFleet
from support.ground_api import ground_clients, heard

pytestmark = pytest.mark.integration
HOME = LLA(40.63, -8.659, 10.0)
FILES = Path(__file__).parents[2] / "support" / "mission_files"


@pytest.fixture
async def platform(embedded_broker, tmp_path):
    async with SimFleet(speedup=10) as fleet:
        await fleet.add_drone(DroneConfig(drone_id="FILE_1"), embedded_broker, home=HOME)
        ready = heard("FILE_1")
        async with ground_clients(
            embedded_broker, tmp_path, "files-test-planner", ready
        ) as clients:
            yield clients


async def imported(op: httpx.AsyncClient, name: str) -> dict:
    r = await op.post("/api/v1/missions/import", content=(FILES / name).read_bytes())
    assert r.status_code == 200, r.text
    return r.json()


async def test_a_qgroundcontrol_plan_imports_and_the_planner_takes_it_as_it_is(platform):
    op, _ = platform
    got = await imported(op, "field-waypoints.plan")
    assert got["kind"] == "plan" and got["home"] == [40.63, -8.659, 10]
    spec = {**got["spec"], "drones": ["FILE_1"]}
    assert len(spec["options"]["rally_points"]) == 2
    preview = await op.post("/api/v1/missions/preview", json=spec)
    assert preview.status_code == 200, preview.text
    assert preview.json()["drones"][0]["drone_id"] == "FILE_1"
    created = await op.post("/api/v1/missions", json=spec)
    assert created.status_code == 201, created.text
    mission_id = created.json()["mission_id"]

    # ... and it goes out again as a .plan that reads back as the same mission.
    exported = await op.get(f"/api/v1/missions/{mission_id}/plan")
    assert exported.status_code == 200, exported.text
    assert 'filename="mission-' in exported.headers["content-disposition"]
    document = exported.json()
    assert document["mission"]["plannedHomePosition"] == pytest.approx([40.63, -8.659, 10])
    assert [i["command"] for i in document["mission"]["items"]] == [22, 16, 16, 203, 16, 20]
    again = await op.post("/api/v1/missions/import", content=exported.content)
    assert again.status_code == 200, again.text
    assert document["mission"]["items"][2]["params"][0] == 3  # the hold, as QGC writes it
    assert again.json()["spec"]["steps"] == got["spec"]["steps"]
    assert again.json()["spec"]["options"] == got["spec"]["options"]


async def test_a_google_earth_field_imports_as_an_area_and_previews(platform):
    op, _ = platform
    got = await imported(op, "field.kml")
    assert got["kind"] == "kml" and got["spec"]["name"] == "North field"
    spec = {**got["spec"], "drones": ["FILE_1"]}
    preview = await op.post("/api/v1/missions/preview", json=spec)
    assert preview.status_code == 200, preview.text
    waypoints = preview.json()["waypoints"]
    assert len(waypoints) > 10

    as_plan = await op.post("/api/v1/missions/preview/plan", json=spec)
    assert as_plan.status_code == 200, as_plan.text
    items = as_plan.json()["mission"]["items"]
    assert [(i["params"][4], i["params"][5]) for i in items if i["command"] == 16] == [
        (w["lat"], w["lon"]) for w in waypoints
    ]


@pytest.mark.parametrize(
    ("body", "why"),
    [
        (b"", "the request body is empty"),
        (b"hello", "not a QGroundControl .plan (JSON) nor a KML"),
        (b'{"fileType": "Plan", "version": 1, "mission": {"items": 3}}', "mission.items"),
        (b'<!DOCTYPE kml [<!ENTITY a "x">]><kml/>', "declares a DTD"),
        ((FILES / "field.kml").read_bytes().replace(b"40.6310", b"95.0"), "out of range"),
    ],
)
async def test_a_bad_file_is_a_422_with_the_reason(platform, body: bytes, why: str):
    op, _ = platform
    r = await op.post("/api/v1/missions/import", content=body)
    assert r.status_code == 422, r.text
    assert why in r.json()["detail"]


async def test_who_may_import_and_export(platform):
    op, view = platform
    plan = (FILES / "field-waypoints.plan").read_bytes()
    nobody = httpx.AsyncClient(base_url=op.base_url, timeout=10)
    async with nobody:
        assert (await nobody.post("/api/v1/missions/import", content=plan)).status_code == 401
    assert (await view.post("/api/v1/missions/import", content=plan)).status_code == 403
    assert (await view.get("/api/v1/missions/nope/plan")).status_code == 404
    body = json.loads(plan)
    assert (await op.post("/api/v1/missions/import?format=kml", content=plan)).status_code == 422
    assert body["fileType"] == "Plan"
