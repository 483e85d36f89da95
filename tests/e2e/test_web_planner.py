"""The Planner page end to end: three-click parallelograms, camera spacing and overlap, the step
list (drag and drop, keyboard), and a mission watched through a handover.
"""

from __future__ import annotations

import json
import math
import re
import time

import pytest
from playwright.sync_api import expect

from .conftest import M_PER_DEG, click_map, get, post_for, wait_landed_at_home

pytestmark = pytest.mark.e2e

DRONE = "QUAD_2"  # previewed only here


def corners(page) -> list[tuple[float, float]]:
    lines = page.input_value("#plan-polygon").splitlines()
    return [tuple(float(v) for v in line.split(",")) for line in lines]


def preview(page):
    """Press Preview; the /missions/preview response."""
    with page.expect_response(lambda r: r.url.endswith("/missions/preview")) as info:
        page.click("#plan-preview")
    assert info.value.ok, f"preview: {info.value.status} {info.value.text()}"
    return info.value


def test_planner_three_clicks_make_a_parallelogram_and_overlap_sets_the_lines(open_page):
    page, console = open_page("planner")
    page.wait_for_selector(f"#plan-drone-{DRONE}")
    page.wait_for_selector("#planner-map .drone-label")  # the map is centred on the fleet
    page.click("#draw-three")
    assert page.get_attribute("#draw-three", "aria-pressed") == "true"
    assert page.get_attribute("#draw-polygon", "aria-pressed") == "false"
    click_map(page, "#planner-map", [(-90, 40), (60, 90)])
    assert len(corners(page)) == 2  # not a shape yet
    click_map(page, "#planner-map", [(100, -70)])
    a, b, c, d = corners(page)
    # The fourth corner closes the parallelogram: d = a + c - b.
    assert d == pytest.approx((a[0] + c[0] - b[0], a[1] + c[1] - b[1]), abs=3e-7)
    assert b[1] > a[1] and c[0] > b[0]  # b east of a, c north of b: as clicked
    shapes = [
        p.get_attribute("d")
        for p in page.locator("#planner-map path[stroke='#2563eb']").all()
        if "a" not in (p.get_attribute("d") or "a")  # not the corner circles
    ]
    assert [s.count("L") for s in shapes] == [3], shapes  # one four-cornered polygon

    # Spacing from the seed's camera: more side overlap, closer lines, more waypoints.
    page.select_option("#plan-spacing-kind", "camera")
    page.fill("#plan-altitude", "15")
    page.check(f"#plan-drone-{DRONE}")
    waypoints = {}
    for overlap in (0.3, 0.8):
        page.fill("#plan-side-overlap", str(overlap))
        answer = preview(page)
        area = answer.request.post_data_json["area"]
        assert "spacing_m" not in area and area["camera"]["side_overlap"] == overlap
        body = answer.json()
        footprint = 6.17 / 2.77 * 15  # sensor width / focal length * altitude
        assert body["spacing_m"] == pytest.approx(footprint * (1 - overlap), rel=0.02)
        waypoints[overlap] = len(body["waypoints"])
        page.wait_for_selector(
            f"#estimate-table caption:text-matches('^{waypoints[overlap]} waypoints')"
        )
    assert waypoints[0.8] > waypoints[0.3] > 0, waypoints
    # Each drone's row shows its colour on the map and what the plan decided for it.
    row = page.locator(f"#estimate-table tr[data-drone='{DRONE}']")
    assert row.locator(".swatch").get_attribute("style").startswith("background:")
    assert row.locator("td.notes").inner_text().strip()
    console.assert_clean()


def test_planner_step_list_is_built_by_drag_and_drop_and_reordered_by_keyboard(open_page):
    # Tall enough that the palette and the list need no scrolling: Playwright's drag scrolls the
    # target into view between pressing and moving, and would then pick up another command.
    page, console = open_page("planner", viewport={"width": 1280, "height": 1600})
    page.wait_for_selector(f"#plan-drone-{DRONE}")
    page.select_option("#plan-kind", "steps")
    step_list = page.locator("#step-list")
    step_list.wait_for()

    def order() -> list[str]:  # the raw commands (each step shows a person's name too)
        return page.locator("#step-list > li").evaluate_all(
            "els => els.map(e => e.dataset.command)"
        )

    def step(i: int):
        return page.locator(f"#step-list > li[data-index='{i}']")

    def drag(source, target, where: str | None = None) -> None:
        """Drag by the item's name (left) onto `target`'s top or bottom edge (or its middle)."""
        size = target.bounding_box()
        y = {"top": 4, "bottom": size["height"] - 4, None: size["height"] / 2}[where]
        grab = source.bounding_box()
        source.drag_to(
            target,
            source_position={"x": 8, "y": grab["height"] / 2},
            target_position={"x": 8, "y": y},
        )

    def palette(name: str):
        return page.locator(f".palette li[data-command='{name}']")

    # From the palette into the list: on a step's top half goes before it, bottom half after it.
    drag(palette("arm"), step_list)
    assert order() == ["arm"]
    drag(palette("land"), step(0), "bottom")
    assert order() == ["arm", "land"]
    drag(palette("takeoff"), step(1), "top")
    assert order() == ["arm", "takeoff", "land"]
    drag(palette("takepic"), step(0), "top")
    assert order() == ["takepic", "arm", "takeoff", "land"]
    # Reordered by dragging the steps themselves: down to the end, then up to the top.
    drag(step(0), step(3), "bottom")
    assert order() == ["arm", "takeoff", "land", "takepic"]
    drag(step(2), step(0), "top")
    assert order() == ["land", "arm", "takeoff", "takepic"]

    # By keyboard: the ↓/↑ buttons, and the focus stays on the moved step.
    page.focus("#step-list button[aria-label='Move step 1 down']")
    for position in (2, 3, 4):
        page.keyboard.press("Enter")
        focused = page.evaluate("document.activeElement.getAttribute('aria-label')")
        assert focused == f"Move step {position} down"
    assert order() == ["arm", "takeoff", "takepic", "land"]
    page.keyboard.press("Enter")  # already last: stays
    assert order() == ["arm", "takeoff", "takepic", "land"]
    page.keyboard.press("Shift+Tab")
    page.keyboard.press("Enter")
    assert order() == ["arm", "takeoff", "land", "takepic"]
    assert page.evaluate("document.activeElement.getAttribute('aria-label')") == "Move step 3 up"
    page.keyboard.press("Tab")  # to "Move step 3 down"
    page.keyboard.press(" ")
    assert order() == ["arm", "takeoff", "takepic", "land"]

    # The mission sent for a preview is that list, in that order.
    page.check(f"#plan-drone-{DRONE}")
    answer = preview(page)
    steps = answer.request.post_data_json["steps"]
    assert [s["command"] for s in steps] == ["arm", "takeoff", "takepic", "land"]
    assert steps[1]["value"] == 10  # the palette's take-off height came along
    page.wait_for_selector(f"#estimate-table tbody th:text-is('{DRONE}')")
    assert page.inner_text("#estimate-table tbody td >> nth=0") == "4"
    console.assert_clean()


def test_the_planner_shows_where_a_handover_happened(open_page, demo, screenshot):
    here = get(demo, "/drones/QUAD_1")["position"]
    steps: list[dict] = []
    for k, (north, east) in enumerate([(20, 0), (20, 20), (0, 20), (0, 0)], start=1):
        lat = here["lat"] + north / M_PER_DEG
        lon = here["lon"] + east / (M_PER_DEG * math.cos(math.radians(here["lat"])))
        steps += [
            {"command": "navigate", "lat": lat, "lon": lon, "altitude_delta": 10},
            {"command": "wait_for_flight"},
        ]
        if k == 2:  # the seed's virtual alarm: this drone must be replaced here
            steps.append({"command": "virtualalarm", "level": "CRITICAL", "message": "smoke"})
    page, console = open_page("planner")
    spec = {
        "name": "handover",
        "drones": ["QUAD_1"],
        "steps": steps,
        "options": {"early_replacement": False, "collaboration": False},
    }
    status, answer = post_for(demo, "/missions?start=true", spec)
    assert status == 201, answer
    mission = json.loads(answer)["mission_id"]
    page.focus("#plan-watch")  # the list of missions is read when it is opened
    page.wait_for_selector(f"#plan-watch option[value='{mission}']", state="attached")
    page.select_option("#plan-watch", mission)
    done = f"#mission-status[data-mission='{mission}'][data-state='completed']"
    page.wait_for_selector(done, timeout=120_000)
    page.wait_for_selector("#mission-status[data-handovers='1']")
    # Leaflet fades a removed tooltip out for 200 ms: a redraw leaves the old label a moment.
    label = page.locator(".handover-label")
    expect(label).to_have_count(1)
    taker = re.fullmatch(r"handover: QUAD_1 → (QUAD_\d) \(on alarm\)", label.inner_text())
    assert taker and taker.group(1) != "QUAD_1", label.inner_text()
    assert "4/4 waypoints" in page.inner_text("#mission-status")
    # The timeline says what replacement did, and each drone has its bar (issue 29).
    events = page.locator("#plan-progress-events li")
    expect(
        events.filter(has_text="CRITICAL alarm on QUAD_1: smoke; replacement is on")
    ).to_have_count(1)
    expect(events.filter(has_text=f"QUAD_1 replaced by {taker.group(1)}")).to_have_count(1)
    expect(events.first).to_contain_text("completed: 4/4 waypoints")  # newest first
    rows = page.locator("#plan-progress-drones tbody tr")
    expect(rows).to_have_count(2)
    first = page.locator("#plan-progress-drones tr[data-drone='QUAD_1']")
    expect(first).to_have_attribute("data-doing", "handed over")
    # Each did its part to the end: the steps handed over are the taker's share, not QUAD_1's.
    assert float(first.get_attribute("data-share")) == 1.0
    after = page.locator(f"#plan-progress-drones tr[data-drone='{taker.group(1)}']")
    assert float(after.get_attribute("data-share")) == 1.0
    reached = [int(re.search(r"(\d+)/\d+ waypoints", row.inner_text()).group(1))
               for row in (first, after)]  # fmt: skip
    assert 0 < reached[0] < 4 and sum(reached) == 4, reached
    screenshot(page, "8-planner-handover")
    console.assert_clean()


def test_the_planner_pauses_and_resumes_a_mission(open_page, demo, screenshot):
    here = get(demo, "/drones/QUAD_2")["position"]
    steps: list[dict] = []
    for north, east in [(30, 0), (30, 30), (0, 30), (0, 0)]:
        lat = here["lat"] + north / M_PER_DEG
        lon = here["lon"] + east / (M_PER_DEG * math.cos(math.radians(here["lat"])))
        steps += [
            {"command": "navigate", "lat": lat, "lon": lon, "altitude_delta": 10},
            {"command": "wait_for_flight"},
        ]
    page, console = open_page("planner")
    spec = {"name": "pause", "drones": ["QUAD_2"], "steps": steps}
    for _ in range(60):  # QUAD_2 may still be coming home from an earlier test
        status, answer = post_for(demo, "/missions?start=true", spec)
        if status != 409:
            break
        time.sleep(1.0)
    assert status == 201, answer
    mission = json.loads(answer)["mission_id"]
    page.focus("#plan-watch")
    page.wait_for_selector(f"#plan-watch option[value='{mission}']", state="attached")
    page.select_option("#plan-watch", mission)
    page.wait_for_selector(f"#mission-status[data-mission='{mission}'][data-state='running']")
    # Its bar moves on and its time left is estimated (issue 29), polled every 3 s.
    row = page.locator("#plan-progress-drones tr[data-drone='QUAD_2']")
    shares = []
    for _ in range(300):  # in the air, its first waypoint flown
        if row.count():
            shares.append(float(row.get_attribute("data-share")))
        if get(demo, f"/missions/{mission}")["steps_done"] >= 2 and shares and shares[-1] > 0:
            break
        time.sleep(0.1)
    expect(row.locator("td.eta")).to_contain_text(re.compile(r"\d+ s left"), timeout=15_000)
    expect(row.locator("td.step")).to_contain_text(re.compile(r"^step \d+/\d+: "))
    assert shares[-1] > 0 and shares == sorted(shares), shares
    page.click("#plan-pause")
    page.wait_for_selector("#mission-status[data-state='paused']", timeout=30_000)
    expect(page.locator("#mission-status")).to_contain_text("paused by the operator")
    events = page.locator("#plan-progress-events li")
    expect(events.filter(has_text="QUAD_2 paused: paused by the operator")).to_have_count(1)
    screenshot(page, "9-planner-paused")
    # The Fleet page shows the running mission too: its bar, step and events.
    fleet, fleet_console = open_page("fleet")
    box = fleet.locator(f"#fleet-missions article[data-mission='{mission}']")
    expect(box.locator("tr[data-drone='QUAD_2'] progress")).to_have_count(1, timeout=15_000)
    expect(box.locator("li[data-kind='paused']")).to_have_count(1)
    screenshot(fleet, "9-fleet-mission-progress")
    fleet_console.assert_clean()
    page.click("#plan-resume")
    done = f"#mission-status[data-mission='{mission}'][data-state='completed']"
    try:
        page.wait_for_selector(done, timeout=120_000)
    except Exception:
        raise AssertionError(get(demo, f"/missions/{mission}")) from None
    assert "4/4 waypoints" in page.inner_text("#mission-status")
    expect(page.locator("#plan-progress-events li[data-kind='resumed']")).to_have_count(1)
    assert row.get_attribute("data-share") == "1" and row.get_attribute("data-doing") == "done"
    console.assert_clean()


def test_the_planner_maps_what_the_drones_measured(open_page, demo, screenshot):
    """The collab experiment's mission (seed 5.4: 28 x 35 m at 7 m, 2 s sensor holds, an
    OUT_MEASURE alarm after waypoint 15 that grows the area and calls the idle drones) flown over
    the demo's CO2 plume: the readings layer shows the plume, every leg's readings on it."""
    from dronefleet.cli.drone import DEFAULT_HOME
    from dronefleet.demo import DEMO_PLUME
    from dronefleet.experiments.scenarios import with_alarm
    from dronefleet.ground.planner.coverage import AreaSpec, plan_area

    lat, lon = (float(v) for v in DEFAULT_HOME.split(",")[:2])  # the centre of the demo's homes
    m_lon = M_PER_DEG * math.cos(math.radians(lat))
    south, west = DEMO_PLUME.n - 17.5, DEMO_PLUME.e - 14.0  # the plume in the field's middle
    corners = [(0, 0), (35, 0), (35, 28), (0, 28)]
    polygon = [[lat + (south + n) / M_PER_DEG, lon + (west + e) / m_lon] for n, e in corners]
    area = {"polygon": polygon, "spacing_m": 7, "altitude_m": 10, "angle_deg": 0,
            "action": "read_sensors", "hold_s": 2, "grid": "seed"}  # fmt: skip
    steps = with_alarm(plan_area(AreaSpec(**area)).mission_steps(), 15, "OUT_MEASURE")
    spec = {"name": "collab", "drones": ["QUAD_3"], "steps": steps, "area": area,
            "options": {"replacement": False, "collaboration": True}}  # fmt: skip
    page, console = open_page("planner")
    for _ in range(60):  # QUAD_3 may still be coming home from an earlier test
        status, answer = post_for(demo, "/missions?start=true", spec)
        if status != 409:
            break
        time.sleep(1.0)
    assert status == 201, answer
    mission = json.loads(answer)["mission_id"]
    page.focus("#plan-watch")
    page.wait_for_selector(f"#plan-watch option[value='{mission}']", state="attached")
    page.select_option("#plan-watch", mission)
    done = f"#mission-status[data-mission='{mission}'][data-state='completed']"
    page.wait_for_selector(done, timeout=240_000)
    record = get(demo, f"/missions/{mission}")
    assert record["expansions"], "the OUT_MEASURE alarm grew no area"
    read = get(demo, f"/missions/{mission}/readings")["features"]
    assert len({f["properties"]["drone_id"] for f in read}) > 1, "no collaborator read a sensor"
    markers = page.locator("#planner-map .reading-marker")
    expect(markers).to_have_count(len(read))
    key = page.inner_text("#readings-key")
    low, high = (float(v) for v in re.findall(r"(?:green|red) (\d+)", key))
    assert high > 1000 > low, key  # the plume stands out of the 400 ppm background
    # What collaboration did, in the timeline (issue 29: it happened without the operator knowing).
    grown = page.locator("#plan-progress-events li[data-kind='expansion']")
    expect(grown).to_contain_text(re.compile(r"alarm on QUAD_3.*: area expanded .* called"))
    screenshot(page, "10-planner-readings")
    console.assert_clean()


def test_the_planner_refuses_a_mission_that_leaves_its_geofence(open_page, demo):
    here = get(demo, f"/drones/{DRONE}")["position"]
    m_lon = M_PER_DEG * math.cos(math.radians(here["lat"]))

    def box(n0: float, e0: float, n1: float, e1: float) -> str:
        pts = [(n0, e0), (n0, e1), (n1, e1), (n1, e0)]
        return "\n".join(
            f"{here['lat'] + n / M_PER_DEG}, {here['lon'] + e / m_lon}" for n, e in pts
        )

    page, console = open_page("planner")
    page.wait_for_selector(f"#plan-drone-{DRONE}")
    page.fill("#plan-polygon", box(10, 0, 50, 30))
    page.dispatch_event("#plan-polygon", "change")
    page.fill("#plan-fence", box(-20, -20, 30, 50))  # the area's north part is outside
    page.dispatch_event("#plan-fence", "change")
    page.check(f"#plan-drone-{DRONE}")
    page.click("#plan-preview")
    expect(page.locator("#plan-estimate")).to_contain_text("outside the inclusion fence")
    assert DRONE in page.inner_text("#plan-estimate")
    page.click("#fence-from-shape")
    assert page.input_value("#plan-fence") == page.input_value("#plan-polygon")
    page.fill("#plan-fence", box(-30, -30, 60, 40))  # the site, the drone's home in it
    page.dispatch_event("#plan-fence", "change")
    preview(page)
    expect(page.locator("#estimate-table")).to_be_visible()
    # The browser logs the refusal's 422 itself; nothing else may fail.
    assert all("status of 422" in e for e in console.errors), console.errors


def test_shift_escape_aborts_every_mission_from_any_page(open_page, demo):
    here = get(demo, "/drones/QUAD_1")["position"]
    steps = [{"command": "navigate", "lat": here["lat"] + 40 / M_PER_DEG, "lon": here["lon"],
              "altitude_delta": 10}, {"command": "wait_for_flight"}]  # fmt: skip
    for _ in range(60):  # QUAD_1 may still be coming home from an earlier test
        status, answer = post_for(demo, "/missions?start=true", {"drones": ["QUAD_1"],
                                                                 "steps": steps})  # fmt: skip
        if status != 409:
            break
        time.sleep(1.0)
    assert status == 201, answer
    mission = json.loads(answer)["mission_id"]
    page, console = open_page("fleet")
    asked: list[str] = []
    page.on("dialog", lambda d: (asked.append(d.message), d.accept()))
    page.keyboard.press("Shift+Escape")
    expect(page.locator(".toast").last).to_contain_text("aborted")
    assert asked and asked[0].startswith("Abort every mission?"), asked
    record = get(demo, f"/missions/{mission}")
    assert record["state"] == "stopped"
    wait_landed_at_home(demo, ["QUAD_1"], after=record["ended_at"], timeout_s=90)
    console.assert_clean()


def add_step(page, command: str) -> None:
    page.click(f".palette li[data-command='{command}'] button")


def test_a_step_lists_preview_draws_its_route_and_counts_its_waypoints(open_page):
    page, console = open_page("planner")
    page.wait_for_selector(f"#plan-drone-{DRONE}")
    page.check(f"#plan-drone-{DRONE}")
    page.select_option("#plan-kind", "steps")
    for command in ("navigate", "wait_for_flight", "navigate", "wait_for_flight"):
        add_step(page, command)
    lat = page.locator("#step-list li[data-index='2'] input[data-param='lat']")
    lat.fill(str(float(lat.input_value()) + 30 / M_PER_DEG))  # 30 m north of the first
    lat.dispatch_event("change")
    body = preview(page).json()
    assert len(body["waypoints"]) == 2, body["waypoints"]
    assert body["waypoints"][1]["lat"] == pytest.approx(float(lat.input_value()))
    page.wait_for_selector("#estimate-table caption:text-matches('^2 waypoints')")
    # The route is drawn per drone in the drone's colour (issue 29, item 8), the step list's too.
    route = page.locator(f"#planner-map path.route-share[data-drone='{DRONE}']")
    expect(route).to_have_count(1)
    assert route.get_attribute("d").count("L") == 1  # one line between the two points
    expect(page.locator(f"#route-legend li[data-drone='{DRONE}']")).to_contain_text("2 waypoints")
    console.assert_clean()


def test_with_its_switches_off_a_mission_calls_no_replacement_and_says_so(
    open_page, demo, screenshot
):
    page, console = open_page("planner")
    drone = "QUAD_2"
    page.wait_for_selector(f"#plan-drone-{drone}")
    # On by default, as the API's options are.
    assert page.is_checked("#plan-replacement") and page.is_checked("#plan-collaboration")
    page.uncheck("#plan-replacement")
    page.uncheck("#plan-collaboration")
    page.check(f"#plan-drone-{drone}")
    page.select_option("#plan-kind", "steps")
    for command in ("navigate", "wait_for_flight"):
        add_step(page, command)
    lat = page.locator("#step-list li[data-index='0'] input[data-param='lat']")
    lat.fill(str(float(lat.input_value()) + 20 / M_PER_DEG))
    lat.dispatch_event("change")
    sent = {}

    def with_an_alarm(route):
        """The palette has no alarm step: the seed's virtual alarm is added on the way."""
        body = route.request.post_data_json
        sent.update(body)
        body["steps"].append({"command": "virtualalarm", "level": "CRITICAL", "message": "smoke"})
        route.continue_(post_data=json.dumps(body))

    page.route(re.compile(r".*/api/v1/missions\?.*start=true.*"), with_an_alarm)
    for _ in range(60):  # QUAD_2 may still be coming home from an earlier test
        if get(demo, f"/drones/{drone}").get("mission_id") is None:
            break
        time.sleep(1.0)
    page.click("#plan-send")
    page.click("#preflight-send")
    page.wait_for_selector("#mission-status[data-mission]", timeout=30_000)
    options = sent["options"]
    assert options["replacement"] is options["early_replacement"] is options["collaboration"]
    assert options["replacement"] is False
    page.wait_for_selector("#mission-status:not([data-state='running'])", timeout=120_000)
    mission = page.get_attribute("#mission-status", "data-mission")
    events = page.locator("#plan-progress-events li[data-kind='alarm']")
    expect(events).to_contain_text(
        f"CRITICAL alarm on {drone}: smoke; replacement is off: nobody takes over", timeout=15_000
    )
    record = get(demo, f"/missions/{mission}")
    assert record["handovers"] == [] and {leg["drone_id"] for leg in record["legs"]} == {drone}
    screenshot(page, "9-planner-replacement-off")
    console.assert_clean()
