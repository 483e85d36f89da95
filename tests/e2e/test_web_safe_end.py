"""Every mission ends safely (issue 14, must-show 1): a survey drawn in the planner and flown by
two drones to completion leaves each of them landed at its own home and disarmed — not hovering
where its share ended, as the seed's missions did."""

from __future__ import annotations

import pytest

from .conftest import click_and_wait, click_map, get, wait_landed_at_home

pytestmark = pytest.mark.e2e
DRONES = ("QUAD_1", "QUAD_2")


def test_a_survey_flown_to_completion_leaves_every_drone_landed_at_home_and_disarmed(
    open_page, screenshot, demo
):
    page, console = open_page("planner")
    for drone in DRONES:
        page.wait_for_selector(f"#plan-drone-{drone}")
    page.wait_for_selector("#planner-map[data-fitted='1']")  # centred on the fleet, settled
    click_map(page, "#planner-map", [(-60, -60), (60, -60), (60, 60), (-60, 60)])
    page.click("#draw-finish")
    page.fill("#plan-spacing", "15")
    for drone in DRONES:
        page.check(f"#plan-drone-{drone}")
    assert page.input_value("#plan-end") == "rtl"  # return to launch unless asked otherwise
    click_and_wait(page, "#plan-preview", "#estimate-table tbody tr")
    # Send shows the pre-flight checklist first: both drones pass, then it is sent.
    click_and_wait(page, "#plan-send", "#preflight[open] table[data-drone='QUAD_2']")
    assert page.get_attribute("#preflight", "data-ok") == "true"
    click_and_wait(page, "#preflight-send", "#mission-status[data-state]")
    page.wait_for_selector("#mission-status[data-state='completed']", timeout=150_000)
    mission = page.get_attribute("#mission-status", "data-mission")
    record = get(demo, f"/missions/{mission}")
    assert {leg["drone_id"] for leg in record["legs"]} == set(DRONES)
    # Each share ends with the way home (RTL, then waiting until the vehicle is down), flown
    # first on a layer of its own when the other drone goes home too (ground/planner/deconflict/).
    ends = [[step["command"] for step in leg["suffix"]] for leg in record["legs"]]
    assert all(end[-2:] == ["rtl", "wait_for_flight"] for end in ends), ends
    wait_landed_at_home(demo, DRONES, after=record["ended_at"])
    screenshot(page, "safe-end-completed")
    console.assert_clean()
