"""The Planner page's mission files and rally points (issue 14), in Chromium against the demo.

A hand-written QGroundControl .plan is imported through the page's file input: its steps fill
the step list, its fence and rally points the form and the map, the speed change it cannot carry
is listed. Export .plan then downloads a file that MAVSDK-Python (``mavsdk_server`` against a
``dronefleet sim``, run beside the browser) imports with the same waypoints, fence and rally
points. A Google Earth KML fills the area, and rally points are added by clicking the map.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import json
from pathlib import Path

import pytest

from .conftest import click_map

pytestmark = pytest.mark.e2e
FILES = Path(__file__).parents[1] / "support" / "mission_files"
HOME = (40.63, -8.659, 10.0)


async def _mavsdk_import(path: Path):
    """MAVSDK's own .plan importer, run as its users run it (a System on a vehicle)."""
    from mavsdk import System

    from dronefleet.messaging.embedded import free_port
    from support.processes import dronefleet_sim

    async with dronefleet_sim(1, HOME, 5.0) as port:
        drone = System(port=free_port())
        await drone.connect(system_address=f"udpout://127.0.0.1:{port}")
        async with asyncio.timeout(30):
            async for state in drone.core.connection_state():
                if state.is_connected:
                    break
        return await drone.mission_raw.import_qgroundcontrol_mission(str(path))


def mavsdk_import(path: Path):
    # Its own thread and event loop: Playwright's sync API owns this thread's.
    with concurrent.futures.ThreadPoolExecutor(1) as pool:
        return pool.submit(asyncio.run, _mavsdk_import(path)).result(timeout=120)


def test_a_qgroundcontrol_plan_is_imported_and_exported_for_mavsdk(open_page, tmp_path, screenshot):
    page, console = open_page("planner")
    page.set_input_files("#plan-import", str(FILES / "field-waypoints.plan"))
    page.wait_for_selector("#plan-import-notes[data-loaded='field-waypoints.plan']")
    assert page.input_value("#plan-kind") == "steps"
    assert page.locator("#step-list > li").count() == 13
    commands = page.locator("#step-list > li").evaluate_all(
        "els => els.map(e => e.dataset.command)"
    )
    assert commands[:4] == ["arm", "takeoff", "wait_for_flight", "navigate"]
    assert len(page.input_value("#plan-fence").splitlines()) == 4
    assert page.input_value("#plan-rally").splitlines() == [
        "40.6312000, -8.6585000, 15", "40.6299000, -8.6580000, 12"
    ]  # fmt: skip
    assert page.locator("#planner-map .rally-marker").count() == 2
    assert page.locator("#planner-map .exclusion-zone").count() == 1
    assert "MAV_CMD_DO_CHANGE_SPEED left out" in page.inner_text("#plan-import-notes")
    screenshot(page, "planner-imported-plan")

    page.check("#plan-drone-QUAD_1")
    # Its route previewed: the imported navigate steps (issue 29: "waypoints": [] before).
    navigate = page.locator("#step-list > li[data-command='navigate']")
    with page.expect_response(lambda r: r.url.endswith("/missions/preview")) as answer:
        page.click("#plan-preview")
    assert answer.value.ok, answer.value.text()
    routed = [(round(w["lat"], 7), round(w["lon"], 7)) for w in answer.value.json()["waypoints"]]
    assert len(routed) == navigate.count() == 3, routed
    assert routed[1] == (40.631, -8.659)
    page.wait_for_selector("#estimate-table caption:text-matches('^3 waypoints')")
    with page.expect_download() as info:
        page.click("#plan-export")
    path = tmp_path / "exported.plan"
    info.value.save_as(path)
    document = json.loads(path.read_text())
    assert document["fileType"] == "Plan"
    console.assert_clean()

    got = mavsdk_import(path)
    waypoints = [(i.x, i.y, round(i.z)) for i in got.mission_items if i.command == 16][1:]
    assert waypoints == [(406303000, -86590000, 15), (406310000, -86590000, 20),
                         (406310000, -86580000, 20)]  # fmt: skip
    assert [i.command for i in got.mission_items][-1] == 20  # the RTL
    assert len(got.geofence_items) == 4 + 36
    assert [(i.x, i.y) for i in got.rally_items] == [(406312000, -86585000),
                                                     (406299000, -86580000)]  # fmt: skip


def test_a_google_earth_field_fills_the_area_and_rally_points_are_clicked(open_page):
    page, console = open_page("planner")
    page.set_input_files("#plan-import", str(FILES / "field.kml"))
    page.wait_for_selector("#plan-import-notes[data-loaded='field.kml']")
    assert page.input_value("#plan-kind") == "area"
    corners = page.input_value("#plan-polygon").splitlines()
    assert corners[0] == "40.6302000, -8.6590000" and len(corners) == 4

    page.click("#rally-mode")
    assert page.get_attribute("#rally-mode", "aria-pressed") == "true"
    click_map(page, "#planner-map", [(-120, 60), (150, -80)])
    page.click("#rally-mode")  # off: clicks draw the area again
    assert len(page.input_value("#plan-rally").splitlines()) == 2
    assert len(page.input_value("#plan-polygon").splitlines()) == 4  # the area kept its corners
    assert page.locator("#planner-map .rally-marker").count() == 2

    page.check("#plan-drone-QUAD_1")
    with page.expect_response(lambda r: r.url.endswith("/missions/preview")) as info:
        page.click("#plan-preview")
    body = info.value.request.post_data_json
    assert len(body["options"]["rally_points"]) == 2
    assert all(p["alt_m"] == 15 for p in body["options"]["rally_points"])
    console.assert_clean()
