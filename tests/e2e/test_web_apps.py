"""The web apps as a person uses them: Chromium on a live ``dronefleet demo`` (issue 5).

Each scenario reads like the seed's: draw an area and fly it, replay its log, call a drone from
a phone, see a drone lost, read a past stretch of telemetry. Every page must log no console error.
"""

from __future__ import annotations

import json
import re
import time
from datetime import UTC, datetime

import pytest
from playwright.sync_api import TimeoutError as PlaywrightTimeout
from playwright.sync_api import expect

from .conftest import _dronefleet as _cli
from .conftest import (
    click_and_wait,
    click_map,
    get,
    post,
    start_process,
    stop_process,
    wait_landed_at_home,
)

pytestmark = pytest.mark.e2e


def test_an_area_drawn_in_the_planner_is_flown_to_completion(open_page, screenshot, shared):
    page, console = open_page("planner")
    page.wait_for_selector("#plan-drone-QUAD_1")
    page.wait_for_selector("#planner-map[data-fitted='1']")  # centred on the fleet, settled
    click_map(page, "#planner-map", [(-80, -80), (80, -80), (80, 80), (-80, 80)])
    page.click("#draw-finish")
    assert len(page.input_value("#plan-polygon").splitlines()) == 4
    page.fill("#plan-spacing", "12")
    page.check("#plan-drone-QUAD_1")
    click_and_wait(page, "#plan-preview", "#estimate-table tbody tr")
    assert "QUAD_1" in page.inner_text("#estimate-table")
    screenshot(page, "1-planner-preview")
    # Send shows the pre-flight checklist first; every check of QUAD_1 passes.
    click_and_wait(page, "#plan-send", "#preflight[open] table[data-drone='QUAD_1']")
    assert page.get_attribute("#preflight", "data-ok") == "true"
    assert page.locator("#preflight td.status[data-status='fail']").count() == 0
    click_and_wait(page, "#preflight-send", "#mission-status[data-state]")
    page.wait_for_selector("#mission-status[data-state='completed']", timeout=90_000)
    shared["mission"] = page.get_attribute("#mission-status", "data-mission")
    screenshot(page, "1-planner-completed")
    console.assert_clean()


def test_the_log_of_that_mission_replays_its_path(open_page, screenshot, shared, demo, tmp_path):
    mission = shared.get("mission") or pytest.fail("needs the planner test's mission")
    log_file = tmp_path / f"mission-{mission}.json"
    log_file.write_text(json.dumps(get(demo, f"/missions/{mission}/log")))
    page, console = open_page("replay")
    page.set_input_files("#replay-file", str(log_file))  # the "drop a log file" path
    page.wait_for_selector(f"#replay-title[data-mission='{mission}']")
    path = page.locator("path.replay-path").first.get_attribute("d")
    assert path and path.count("L") >= 3, f"no path drawn: {path!r}"
    assert page.locator("#replay-step-table tbody tr").count() > 3
    page.fill("#replay-time", "300")
    page.dispatch_event("#replay-time", "input")
    assert "of" in page.inner_text("#replay-clock")
    screenshot(page, "2-replay")
    # The same log, picked from the finished missions.
    page.select_option("#replay-mission", mission)
    page.wait_for_selector(f"#replay-title[data-mission='{mission}']")
    console.assert_clean()


def test_calling_from_a_phone_100_m_away_brings_a_drone(open_page, screenshot, demo):
    drone = next(d for d in get(demo, "/drones") if d["drone_id"] == "QUAD_3")
    lat = drone["position"]["lat"] + 100 / 111_320  # 100 m north
    lon = drone["position"]["lon"]
    page, console = open_page(
        "call",
        geolocation={"latitude": lat, "longitude": lon},
        permissions=["geolocation"],
        viewport={"width": 390, "height": 844},
        is_mobile=True,
        has_touch=True,
    )
    page.evaluate(  # every ETA the page shows, as it shows it
        """() => { window.etas = [];
             new MutationObserver(() => {
               const eta = document.getElementById('call-status').dataset.etaS;
               if (eta && eta !== window.etas.at(-1)) window.etas.push(eta);
             }).observe(document.getElementById('call-status'), {attributes: true}); }"""
    )
    click_and_wait(page, "#call-button", "#call-status[data-state='coming']")
    assert re.search(r"QUAD_\d is coming: \d+ m away, about \d", page.inner_text("#call-status"))
    # The drone that comes has its panel: its figures and its own buttons (issue 14).
    expect(page.locator("#call-panel[data-drone] [data-figure='gps']")).to_contain_text("3-D fix")
    screenshot(page, "3-call-coming")
    page.wait_for_selector("#call-status[data-state='arrived']", timeout=90_000)
    screenshot(page, "3-call-arrived")
    etas = [float(e) for e in page.evaluate("window.etas")]
    assert len(etas) >= 3 and etas[-1] == 0 and max(etas) > etas[-2] > 0, etas
    console.assert_clean()
    # A call ends hovering above the caller until someone sends the drone home: sent here, so
    # that the shared demo's later tests find it at home with a fresh battery, not hovering with
    # what however long they took has left it (the operator test's mission, given a hovering
    # QUAD_1 at 20 %, is handed to another drone at once and QUAD_1 comes home: a CI run whose
    # browser tests took 11:48 failed on that; an 8-minute run had left it 37 %).
    came = page.get_attribute("#call-panel", "data-drone")
    sent_at = get(demo, f"/drones/{came}")["last_seen"]
    assert post(demo, f"/drones/{came}/commands/rtl") == 200
    wait_landed_at_home(demo, [came], after=sent_at, timeout_s=90)


def test_a_drone_whose_process_stops_is_shown_lost(open_page, screenshot, demo, tmp_path):
    home = get(demo, "/drones")[0]["home"]
    where = f"{home['lat'] + 0.0003},{home['lon']},{home['alt_m']}"
    broker, secret = demo.joins["LONE_1"]  # its own broker credentials (issue 12)
    args = [*_cli(), "drone", "--id", "LONE_1", "--fc", "sim", "--broker", broker]
    args += ["--broker-password-file", secret]
    args += ["--speedup", "5", "--home", where, "--heartbeat-s", "1"]
    process = start_process(args, tmp_path / "drone.log")
    try:
        page, console = open_page("fleet")
        page.wait_for_selector(
            "#fleet-table tr[data-drone='LONE_1'][data-status='online']", timeout=30_000
        )
        screenshot(page, "4-fleet-online")
        page.click("h1")  # the operator has touched the page: alarms may sound (issue 14)
    finally:
        stop_process(process)
    page.wait_for_selector(
        "#fleet-table tr[data-drone='LONE_1'][data-status='lost']", timeout=30_000
    )
    assert "LOST" in page.inner_text("#fleet-table tr[data-drone='LONE_1']")
    expect(page.locator(".toast.error", has_text="drone LONE_1 lost")).to_be_visible()
    assert int(page.get_attribute("#mute", "data-beeps")) >= 1  # a lost drone beeps
    assert page.locator(".drone-label", has_text="LONE_1 (lost)").count() == 1
    screenshot(page, "4-fleet-lost")
    console.assert_clean()


def test_the_telemetry_page_charts_a_past_time_range(open_page, screenshot):
    page, console = open_page("telemetry", timezone_id="UTC")
    page.wait_for_selector("#tm-f-battery_pct")
    now = time.time()
    stamp = lambda t: datetime.fromtimestamp(t, UTC).strftime("%Y-%m-%dT%H:%M:%S")  # noqa: E731
    for box in page.locator("#tm-drones input").all():
        box.set_checked(box.get_attribute("value") in {"QUAD_1", "QUAD_2"})
    page.select_option("#tm-range", "between")
    page.fill("#tm-from", stamp(now - 600))
    page.fill("#tm-to", stamp(now - 5))
    page.click("#tm-show")
    chart = page.locator("#tm-charts figure[data-field='battery_pct']")
    try:
        chart.wait_for(timeout=60_000)
    except PlaywrightTimeout:  # say what the page says (seen once in ~15 runs: no chart)
        toasts = page.locator("#toasts").inner_text()
        pytest.fail(f"no chart; note {page.inner_text('#tm-note')!r}, toasts {toasts!r}")
    assert int(chart.get_attribute("data-points")) > 3
    screenshot(page, "5-telemetry")
    console.assert_clean()


def test_a_viewer_sees_the_fleet_but_cannot_command(open_page, demo):
    page, console = open_page("control", token=demo.viewer)
    assert page.locator("button.command[data-command='arm']").is_disabled()
    console.assert_clean()  # before the refused command below, which Chromium logs
    status = page.evaluate(
        """async (token) => (await fetch('/api/v1/drones/QUAD_2/commands/arm',
             {method: 'POST', headers: {Authorization: 'Bearer ' + token}})).status""",
        demo.viewer,
    )
    assert status == 403
