"""An operator's controls (issue 14), in Chromium on the demo: the per-drone panel and its
buttons, the planner's step list (names, units, where a new point goes, refusals beside their
step), the pre-flight checklist and its override, and the replay's player and log download.
"""

from __future__ import annotations

import json
import math
import re
import time
from pathlib import Path

import pytest
from playwright.sync_api import expect

from .a11y import blocking, describe, run_axe
from .conftest import M_PER_DEG, get, post_for, start_process, stop_process
from .conftest import _dronefleet as _cli

pytestmark = pytest.mark.e2e


def start_mission(demo, spec: dict) -> str:
    """POST /missions?start=true, waiting out a drone still busy with an earlier test."""
    for _ in range(90):
        status, answer = post_for(demo, "/missions?start=true", spec)
        if status != 409:
            break
        time.sleep(1.0)
    assert status == 201, answer
    return json.loads(answer)["mission_id"]


def until(what: str, check, timeout_s: float = 40.0):
    deadline = time.monotonic() + timeout_s
    while not (got := check()):
        if time.monotonic() > deadline:
            pytest.fail(f"never {what}")
        time.sleep(0.3)
    return got


def around(position: dict, north_m: float, east_m: float) -> tuple[float, float]:
    m_lon = M_PER_DEG * math.cos(math.radians(position["lat"]))
    return position["lat"] + north_m / M_PER_DEG, position["lon"] + east_m / m_lon


def test_the_fleet_panel_shows_a_drone_and_acts_on_it_alone(open_page, demo, screenshot, shared):
    here = get(demo, "/drones/QUAD_1")["home"]
    steps = []
    for north, east in [(60, 0), (60, 60), (0, 60)]:
        lat, lon = around(here, north, east)
        steps.append({"command": "navigate", "lat": lat, "lon": lon, "altitude_delta": 12})
        steps.append({"command": "wait_for_flight"})
    mission = start_mission(demo, {"name": "panel", "drones": ["QUAD_1"], "steps": steps})
    page, console = open_page("fleet")
    asked: list[str] = []
    reply = {"accept": True}
    page.on(
        "dialog",
        lambda d: (asked.append(d.message), d.accept() if reply["accept"] else d.dismiss()),
    )
    page.click("#fleet-table button.select[data-drone='QUAD_1']")
    panel = page.locator("#fleet-panel[data-drone='QUAD_1']")

    def figure(key: str):
        return panel.locator(f"[data-figure='{key}']")

    expect(figure("state")).to_have_text("flying", timeout=30_000)
    drone = get(demo, "/drones/QUAD_1")
    pct = drone["battery"]["remaining_pct"]
    word = "OK" if pct >= 40 else "LOW" if pct >= 20 else "CRITICAL"
    assert figure("battery").inner_text().endswith(f"% {word}")
    assert figure("battery").get_attribute("data-level") == {"OK": "ok", "LOW": "warn"}.get(
        word, "critical"
    )
    assert figure("gps").inner_text() == "3-D fix, 12 satellites"
    assert figure("link").inner_text().startswith("online, heard")
    assert figure("wind").inner_text() == "0.0 m/s from 180°"  # the demo's world is calm
    # The drone's own word: its heartbeat names the mission it flies (a drone still flying home
    # from an earlier test shows "flying" before this mission's first heartbeat).
    expect(figure("mission")).to_have_text(mission, timeout=30_000)
    for key, unit in [("altitude", " m"), ("speed", " m/s"), ("home", " m")]:
        assert figure(key).inner_text().endswith(unit), (key, figure(key).inner_text())
    # What the battery left above the 20 % reserve lasts at the drone's current: QUAD_1 has
    # flown the browser tests before this one (at 19 % the panel rightly showed "0 s").
    drone = get(demo, "/drones/QUAD_1")
    battery, flight = drone["battery"], drone["flight"]
    current = battery["current_a"] if battery.get("current_a", 0) > 1 else flight["hover_current_a"]
    left = max(0.0, battery["remaining_pct"] - 20) / 100 * flight["capacity_mah"] / current * 3.6
    shown = re.fullmatch(r"(?:(\d+) min )?(\d+) s", figure("time-left").inner_text())
    assert shown, figure("time-left").inner_text()
    shown_s = int(shown[1] or 0) * 60 + int(shown[2])
    assert abs(shown_s - left) <= 0.1 * left + 5, (shown_s, left, battery)
    # Climbing from home (the call test sends its drone home): above 1 m within the take-off.
    until("above 1 m", lambda: float(figure("altitude").inner_text().split()[0]) > 1)
    # Pause: QUAD_1 holds, its mission is paused; Resume flies on.
    page.click("#fleet-panel-pause")
    until("paused", lambda: get(demo, f"/missions/{mission}")["state"] == "paused")
    screenshot(page, "fleet-panel-paused")
    page.click("#fleet-panel-resume")
    until("resumed", lambda: get(demo, f"/missions/{mission}")["state"] == "running")
    # Its mission's log, downloaded from the panel.
    with page.expect_download() as info:
        page.click("#fleet-panel-log")
    log = json.loads(Path(info.value.path()).read_text())
    assert log["mission_id"] == mission and log["drones"][0]["drone_id"] == "QUAD_1"
    # RTL asks first; refused, nothing is sent.
    sent: list[str] = []
    page.on("request", lambda r: r.method == "POST" and sent.append(r.url))
    reply["accept"] = False
    page.click("#fleet-panel-rtl")
    assert asked[-1].startswith("Send QUAD_1 home now (RTL)?") and not sent
    # Abort asks first; accepted, its part ends and it comes home (the mission's only drone).
    reply["accept"] = True
    page.click("#fleet-panel-abort")
    assert asked[-1].startswith("Abort QUAD_1's part of its mission?")
    stopped = until(
        "stopped", lambda: (m := get(demo, f"/missions/{mission}"))["state"] == "stopped" and m
    )
    assert "home" in stopped["error"] and stopped["legs"][-1]["prefix"][0]["command"] == "rtl"
    shared.setdefault("mission", mission)
    console.assert_clean()


def test_the_control_page_shows_the_chosen_drones_panel_and_a_viewer_cannot_act(open_page, demo):
    page, console = open_page("control")
    page.wait_for_selector("#control-drone option[value='QUAD_2']", state="attached")
    page.select_option("#control-drone", "QUAD_2")
    panel = page.locator("#control-panel[data-drone='QUAD_2']")
    expect(panel.locator("[data-figure='gps']")).to_have_text("3-D fix, 12 satellites")
    mission = get(demo, "/drones/QUAD_2")["mission_id"]
    assert page.locator("#control-panel-pause").is_disabled() == (mission is None)
    console.assert_clean()
    viewer, console = open_page("control", token=demo.viewer)
    viewer.wait_for_selector("#control-panel[data-drone] [data-figure='battery']")
    for action in ("pause", "resume", "abort", "rtl"):
        assert viewer.locator(f"#control-panel-{action}").is_disabled()
    console.assert_clean()


def test_the_step_list_has_names_units_a_sensible_new_point_and_refusals_at_their_step(
    open_page, demo
):
    page, console = open_page("planner")
    page.wait_for_selector("#plan-drone-QUAD_2")
    page.check("#plan-drone-QUAD_2")
    page.select_option("#plan-kind", "steps")
    for name in ("Arm the motors", "Take off", "Land here", "Fly to a point"):
        page.click(f".palette button[aria-label='Add {name}']")
    items = page.locator("#step-list > li")
    assert items.locator("strong").all_inner_texts() == [
        "Arm the motors", "Take off", "Land here", "Fly to a point"
    ]  # fmt: skip
    assert items.locator("code.raw").all_inner_texts() == ["arm", "takeoff", "land", "navigate"]
    # The new point is where QUAD_2 was launched from, not 0°, 0°.
    home = get(demo, "/drones/QUAD_2")["home"]
    nav = page.locator("#step-list > li[data-index='3']")
    assert float(nav.locator("input[data-param='lat']").input_value()) == pytest.approx(
        home["lat"], abs=1e-6
    )
    assert float(nav.locator("input[data-param='lon']").input_value()) == pytest.approx(
        home["lon"], abs=1e-6
    )
    # Every number says its unit: step parameters in their names, the form in its labels.
    labels = page.locator("#step-list input[type='number']").evaluate_all(
        "els => els.map(e => e.getAttribute('aria-label'))"
    )
    assert labels and all(label.endswith(("(m)", "(°)", "(s)")) for label in labels), labels
    units = page.evaluate(
        """() => [...document.querySelectorAll('#tab-area input[type=number]')]
             .map(i => document.querySelector(`label[for='${i.id}']`).textContent)"""
    )
    assert units and all(any(u in t for u in ("(m", "(s", "(°", "fraction")) for t in units), units
    # After the land, a new point needs a new take-off: refused, and said beside step 4.
    page.click("#plan-preview")
    problem = page.locator("#step-list > li.step-error[data-index='3'] .step-problem")
    expect(problem).to_contain_text(
        "step 3 (navigate): the drone is on the ground after the land at step 2"
    )
    assert page.locator("#step-list > li.step-error").count() == 1
    # Moving the land last makes it flyable: the mark goes, the preview says how it ends.
    page.click("#step-list button[aria-label='Move step 3 down']")
    expect(page.locator("#step-list > li.step-error")).to_have_count(0)
    page.select_option("#plan-end", "rtl")
    page.click("#plan-preview")
    expect(page.locator("#estimate-table caption")).to_contain_text(
        "when done: return home and land"
    )
    # The list ends with its own landing: nothing is appended.
    assert page.inner_text("#estimate-table td.ends") == "its own landing"
    assert all("status of 422" in e for e in console.errors), console.errors


def _clear_spot(fleet: list[dict]) -> dict:
    """A home for a drone of the test's own, 40 m or more from every drone of the demo (where
    it is and where its home is: an earlier test may have left one hovering), so that the plan's
    separation check has nothing to refuse (ground/planner/deconflict/)."""
    first = fleet[0]["home"]
    places = [d[key] for d in fleet for key in ("home", "position") if d.get(key)]
    for north_m, east_m in ((-60, 0), (-60, 60), (0, 80), (60, 60), (-60, -60), (0, -80)):
        lat, lon = around(first, north_m, east_m)
        spot = {"lat": lat, "lon": lon, "alt_m": first["alt_m"]}
        if all(_apart_m(spot, p) >= 40 for p in places):
            return spot
    raise AssertionError(f"no clear spot around {first}")


def _apart_m(a: dict, b: dict) -> float:
    north_m = (a["lat"] - b["lat"]) * M_PER_DEG
    east_m = (a["lon"] - b["lon"]) * M_PER_DEG * math.cos(math.radians(a["lat"]))
    return math.hypot(north_m, east_m)


def test_a_failed_preflight_check_needs_an_override_with_a_reason(
    open_page, demo, tmp_path, screenshot
):
    home = _clear_spot(get(demo, "/drones"))
    where = f"{home['lat']},{home['lon']},{home['alt_m']}"
    broker, secret = demo.joins["LONE_1"]
    args = [*_cli(), "drone", "--id", "LONE_1", "--fc", "sim", "--broker", broker]
    args += ["--broker-password-file", secret, "--speedup", "5", "--home", where]
    args += ["--heartbeat-s", "1", "--wind", "14@270"]  # a gale from the west, on its vehicle
    process = start_process(args, tmp_path / "lone.log")
    mission = None
    try:
        until("LONE_1 online", lambda: any(
            d["drone_id"] == "LONE_1" and d["status"] == "online" and d.get("wind")
            for d in get(demo, "/drones")), timeout_s=60)  # fmt: skip
        page, console = open_page("planner")
        page.wait_for_selector("#plan-drone-LONE_1")
        page.check("#plan-drone-LONE_1")
        page.select_option("#plan-kind", "steps")
        for name in ("Fly to a point", "Wait until there", "Take a picture"):
            page.click(f".palette button[aria-label='Add {name}']")
        page.fill(
            "#step-list > li[data-index='0'] input[data-param='lat']", str(home["lat"] + 0.0002)
        )
        page.dispatch_event("#step-list > li[data-index='0'] input[data-param='lat']", "change")
        page.click("#plan-send")
        dialog = page.locator("#preflight[open]")
        wind = dialog.locator("table[data-drone='LONE_1'] tr[data-check='wind']")
        expect(wind.locator("td.status")).to_have_text("✗ FAIL")
        assert "14.0 m/s from 270°, above 8.0 m/s" in wind.inner_text()
        passed = dialog.locator("td.status[data-status='pass']").count()
        assert passed == 4, dialog.inner_text()  # battery, GPS, link, sensors (the camera)
        expect(page.locator("#preflight-send")).to_be_disabled()
        expect(page.locator("#preflight-send")).to_have_text("Override and send")
        found = blocking(run_axe(page))
        assert not found, describe(found)
        reason = "gusts measured on site at 4 m/s; the gale is the sim's"
        page.fill("#preflight-reason", reason)
        expect(page.locator("#preflight-send")).to_be_enabled()
        screenshot(page, "planner-preflight-override")
        with page.expect_response(lambda r: "/missions?" in r.url) as sent:
            page.click("#preflight-send")
        assert sent.value.status == 201, sent.value.text()
        assert "override=" in sent.value.url
        mission = sent.value.json()["mission_id"]
        expect(page.locator(".toast").last).to_contain_text("(checks overridden)")
        audit = get(demo, "/audit?limit=50")
        (entry,) = [
            a
            for a in audit
            if a["command"] == "mission.preflight_override" and a["params"]["reason"] == reason
        ]
        assert any("LONE_1 wind" in f for f in entry["params"]["failed"]), entry
        # The planner's own mission-log button saves the mission it sent.
        with page.expect_download() as info:
            page.click("#plan-log")
        assert json.loads(Path(info.value.path()).read_text())["mission_id"] == mission
        console.assert_clean()
    finally:
        if mission:  # home before its process goes (a lost drone's work would be handed on)
            post_for(demo, f"/missions/{mission}/abort")
        stop_process(process)


def test_the_replay_plays_at_speed_pauses_counts_handovers_and_downloads_its_log(
    open_page, demo, shared, tmp_path, screenshot
):
    mission = shared.get("mission") or pytest.fail("needs a finished mission from a test above")
    log = get(demo, f"/missions/{mission}/log")
    # The same log as if one handover had happened: the title counts it (it said
    # "[object Object] handover(s)").
    handover = {"kind": "on alarm", "from_drone": "QUAD_1", "to_drone": "QUAD_2", "at_step": 1}
    crafted = tmp_path / "with-handover.json"
    crafted.write_text(json.dumps({**log, "handovers": [handover]}))
    page, console = open_page("replay")
    page.set_input_files("#replay-file", str(crafted))
    title = page.locator(f"#replay-title[data-mission='{mission}']")
    expect(title).to_contain_text("1 handover(s)")
    assert "object" not in title.inner_text()
    page.focus("#replay-mission")
    page.select_option("#replay-mission", mission)
    expect(page.locator("#replay-title")).to_contain_text(f"{len(log['handovers'])} handover(s)")
    with page.expect_download() as info:
        page.click("#replay-download")
    assert json.loads(Path(info.value.path()).read_text())["mission_id"] == mission
    speeds = [f"{x}\N{MULTIPLICATION SIGN}" for x in (1, 2, 5, 10)]
    assert page.locator("#replay-speed option").all_inner_texts() == speeds
    page.select_option("#replay-speed", "10")
    page.click("#replay-play")  # from the start: the slider stood at the end
    expect(page.locator("#replay-play")).to_have_attribute("aria-pressed", "true")
    page.wait_for_timeout(1000)
    moving = int(page.input_value("#replay-time"))
    assert 0 < moving < 1000, moving
    page.click("#replay-play")  # pause
    expect(page.locator("#replay-play")).to_have_attribute("aria-pressed", "false")
    held = int(page.input_value("#replay-time"))
    page.wait_for_timeout(600)
    assert int(page.input_value("#replay-time")) == held
    screenshot(page, "replay-player")
    console.assert_clean()
