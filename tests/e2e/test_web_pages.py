"""The web apps' other features, end to end: control, drawing and step lists in the Planner, live
telemetry, map tiles, recovery from a server restart, the phone layout.

QUAD_2 is this module's drone (test_web_apps.py flies QUAD_1 and calls QUAD_3); its test lands
it again. The map-tile and restart scenarios start demos of their own on loopback.
"""

from __future__ import annotations

import json
import math
import re
import struct
import threading
import time
import urllib.error
import urllib.request
import zlib
from collections.abc import Callable
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from urllib.parse import urlsplit

import pytest

from .conftest import click_map, free_port, get, start_demo

pytestmark = pytest.mark.e2e

DRONE = "QUAD_2"
REFUSED = "Failed to load resource: the server responded with a status of 409 (Conflict)"
#: What Chromium logs while the server is down: failed fetches and WebSocket connections.
CONNECTION_LOST = re.compile(r"net::ERR_CONNECTION_REFUSED|WebSocket connection to .* failed")
LOOPBACK = {"127.0.0.1", "localhost"}
M_PER_DEG = 111_320.0


def offset_m(a: dict, b: dict) -> tuple[float, float]:
    """(north, east) metres from position `a` to `b` (flat earth: fine over tens of metres)."""
    north = (b["lat"] - a["lat"]) * M_PER_DEG
    east = (b["lon"] - a["lon"]) * M_PER_DEG * math.cos(math.radians(a["lat"]))
    return north, east


def wait_for_drone(demo, what: str, check: Callable[[dict], bool], timeout_s: float = 40) -> dict:
    """Poll GET /drones/QUAD_2 until `check(record)`; fail saying `what` did not happen."""
    deadline = time.monotonic() + timeout_s
    while True:
        drone = get(demo, f"/drones/{DRONE}")
        if check(drone):
            return drone
        if time.monotonic() > deadline:
            pytest.fail(f"{DRONE} never {what}: {drone}")
        time.sleep(0.3)


def post_for(demo, path: str, body: dict | None = None) -> tuple[int, bytes]:
    """POST /api/v1{path} as the operator; the status and the body of the answer."""
    request = urllib.request.Request(
        f"{demo.url}/api/v1{path}",
        data=json.dumps(body or {}).encode(),
        headers={"Authorization": f"Bearer {demo.operator}", "Content-Type": "application/json"},
        method="POST",
    )
    try:
        with urllib.request.urlopen(request, timeout=20) as answer:
            return answer.status, answer.read()
    except urllib.error.HTTPError as exc:
        return exc.code, exc.read()


def post(demo, path: str, body: dict | None = None) -> int:
    """POST /api/v1{path} as the operator; the status (for clean-ups)."""
    return post_for(demo, path, body)[0]


def command(page, name: str, act: Callable[[], None], expect: str = "done"):
    """Do `act` (press a button, click the map); wait for the page to show the drone's answer.

    Returns (the result text, the answer as JSON or None).
    """
    result = page.locator("#control-result")
    act()
    page.wait_for_selector(
        f"#control-result[data-command='{name}']:not([data-state='sending'])", timeout=40_000
    )
    text, state = result.inner_text(), result.get_attribute("data-state")
    assert state == expect, f"{name}: expected {expect}, the page shows {text!r}"
    return text, (json.loads(text) if state == "done" else None)


def wait_for_option(page, state: str) -> None:
    """The drone picker shows QUAD_2's state (it follows the heartbeats)."""
    page.wait_for_function(
        """([id, state]) => {
             const o = document.querySelector(`#control-drone option[value='${id}']`);
             return o && o.textContent.endsWith(`— ${state}`);
           }""",
        arg=[DRONE, state],
        timeout=20_000,
    )


# -- 1. Control ------------------------------------------------------------------------------------
def test_control_flies_quad_2_and_asks_before_destructive_commands(open_page, demo, screenshot):
    page, console = open_page("control")
    page.wait_for_selector(f"#control-drone option[value='{DRONE}']", state="attached")
    page.select_option("#control-drone", DRONE)
    start = get(demo, f"/drones/{DRONE}")
    assert start["state"] == "disarmed" and start["position"]["relative_alt_m"] < 0.5, start
    sent: list[str] = []
    page.on("request", lambda r: "/commands/" in r.url and sent.append(r.url.rsplit("/", 1)[1]))
    dialogs: list[str] = []
    reply = {"accept": False}

    def on_dialog(dialog) -> None:
        dialogs.append(dialog.message)
        dialog.accept() if reply["accept"] else dialog.dismiss()

    page.on("dialog", on_dialog)

    def press(name: str) -> Callable[[], None]:
        return lambda: page.click(f"button.command[data-command='{name}']")

    try:
        # Arm, then take off to 12 m: the answers show, the state follows on the page and API.
        _, answer = command(page, "arm", press("arm"))
        assert answer["ok"] is True and answer["drone_id"] == DRONE
        wait_for_drone(demo, "armed", lambda d: d["state"] == "armed")
        wait_for_option(page, "armed")
        page.fill("#control-altitude", "12")
        _, answer = command(page, "takeoff", press("takeoff"))
        assert answer["result"]["target"]["alt_m"] == pytest.approx(start["home"]["alt_m"] + 12)
        wait_for_drone(
            demo,
            "took off",
            lambda d: d["state"] == "flying" and d["position"]["relative_alt_m"] > 11,
        )
        wait_for_option(page, "flying")

        # Move north, east and up by the 5 m step.
        moves = {"changeN": (5, 0, 0), "changeE": (0, 5, 0), "altitude": (0, 0, 5)}
        for name, (north, east, up) in moves.items():
            here = get(demo, f"/drones/{DRONE}")["position"]
            _, answer = command(page, name, press(name))
            target = answer["result"]["target"]
            assert offset_m(here, target) == pytest.approx((north, east), abs=1.5), name
            assert target["alt_m"] - here["alt_m"] == pytest.approx(up, abs=1.5), name

            def arrived(d, here=here, north=north, east=east, up=up) -> bool:
                n, e = offset_m(here, d["position"])
                climb = d["position"]["alt_m"] - here["alt_m"]
                return math.dist((n, e, climb), (north, east, up)) < 1.0

            wait_for_drone(demo, f"moved ({name})", arrived)

        # Go to a clicked point: 70 px east and 50 px north of QUAD_2's marker (zoom 19).
        here = get(demo, f"/drones/{DRONE}")["position"]
        marker = page.locator(
            "#control-map .leaflet-marker-icon",
            has=page.locator(f".drone-label:text-is('{DRONE}')"),
        )
        icon = marker.bounding_box()
        x, y = icon["x"] + icon["width"] / 2 + 70, icon["y"] + icon["height"] / 2 - 50
        area = page.locator("#control-map").bounding_box()
        assert (
            area["x"] < x < area["x"] + area["width"] and area["y"] < y < area["y"] + area["height"]
        )
        _, answer = command(page, "navigate", lambda: page.mouse.click(x, y))
        target = answer["result"]["target"]
        m_per_px = 156_543.03 * math.cos(math.radians(here["lat"])) / 2**19
        assert offset_m(here, target) == pytest.approx((50 * m_per_px, 70 * m_per_px), abs=3.0)
        assert target["alt_m"] == pytest.approx(start["home"]["alt_m"] + 12)  # "the altitude above"
        wait_for_drone(
            demo,
            "reached the clicked point",
            lambda d: math.dist(offset_m(target, d["position"]), (0, 0)) < 2,
        )
        screenshot(page, "6-control-flying")

        # Destructive commands ask first; dismissed, nothing is sent.
        for name, label in (("disarm", "Disarm"), ("land", "Land"), ("resetfc", "Reset")):
            before = len(sent)
            page.click(f"button.command[data-command='{name}']")
            assert dialogs and dialogs[-1].startswith(f"{label} {DRONE}?"), dialogs
            page.wait_for_timeout(300)  # a request would have left by now
            assert sent[before:] == [], f"{name} was sent although the dialog was dismissed"
            assert page.get_attribute("#control-result", "data-command") == "navigate"

        # Accepted: sent. Disarming in flight is refused (not forced) and the page says why.
        reply["accept"] = True
        text, _ = command(page, "disarm", press("disarm"), expect="failed")
        assert sent[-1] == "disarm"
        assert "refused disarm" in text and "land first" in text, text
        assert get(demo, f"/drones/{DRONE}")["state"] == "flying"
        screenshot(page, "6-control-disarm-refused")
        _, answer = command(page, "land", press("land"))
        assert sent[-1] == "land" and answer["ok"] is True
        wait_for_drone(
            demo,
            "landed",
            lambda d: d["state"] == "disarmed" and d["position"]["relative_alt_m"] < 0.5,
            timeout_s=60,
        )
        wait_for_option(page, "disarmed")

        # Forced: ticked, the disarm carries force and, in the air, the motors stop: it falls.
        bodies: list[str] = []
        page.on(
            "request", lambda r: r.url.endswith("/commands/disarm") and bodies.append(r.post_data)
        )
        command(page, "arm", press("arm"))
        page.fill("#control-altitude", "4")
        command(page, "takeoff", press("takeoff"))
        wait_for_drone(demo, "up again", lambda d: d["position"]["relative_alt_m"] > 3)
        page.check("#control-force")
        _, answer = command(page, "disarm", press("disarm"))
        assert dialogs[-1].startswith(f"Force disarm {DRONE}?"), dialogs
        assert answer["ok"] is True and json.loads(bodies[-1]) == {"force": True}, bodies
        wait_for_drone(
            demo,
            "fallen and disarmed",
            lambda d: d["state"] == "disarmed" and d["position"]["relative_alt_m"] < 0.5,
            timeout_s=60,
        )
        page.uncheck("#control-force")
    finally:
        if get(demo, f"/drones/{DRONE}")["position"]["relative_alt_m"] > 0.5:
            post(demo, f"/drones/{DRONE}/commands/land")  # never leave it flying
    console.errors.remove(REFUSED)  # the refused disarm, sent on purpose (once)
    console.assert_clean()


# -- 2. Planner ------------------------------------------------------------------------------------
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
    console.assert_clean()


def test_planner_step_list_is_built_by_drag_and_drop_and_reordered_by_keyboard(open_page):
    page, console = open_page("planner")
    page.wait_for_selector(f"#plan-drone-{DRONE}")
    page.select_option("#plan-kind", "steps")
    step_list = page.locator("#step-list")
    step_list.wait_for()

    def order() -> list[str]:
        return page.locator("#step-list > li > strong").all_inner_texts()

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


# -- 3. Telemetry ----------------------------------------------------------------------------------
def test_telemetry_live_mode_keeps_adding_points(open_page):
    page, console = open_page("telemetry")
    page.wait_for_selector("#tm-f-battery_pct")
    page.fill("#tm-minutes", "15")  # a window the demo has not filled yet: points only add up
    page.check("#tm-live")
    page.click("#tm-show")
    chart = "#tm-charts figure[data-field='battery_pct']"
    page.wait_for_selector(chart)
    seen = [int(page.get_attribute(chart, "data-points"))]
    for _ in range(2):  # grows, and grows again, with nothing pressed
        page.wait_for_function(
            "([sel, n]) => Number(document.querySelector(sel)?.dataset.points) > n",
            arg=[chart, seen[-1]],
            timeout=30_000,
        )
        seen.append(int(page.get_attribute(chart, "data-points")))
    assert seen[0] < seen[1] < seen[2], seen
    # Live off: no more queries (the live timer ticks every 3 s).
    queries: list[str] = []
    page.uncheck("#tm-live")
    page.wait_for_timeout(500)  # a query already under way finishes
    page.on("request", lambda r: "/api/v1/telemetry" in r.url and queries.append(r.url))
    page.wait_for_timeout(3_500)
    assert queries == []
    console.assert_clean()


# -- 4. Map tiles ----------------------------------------------------------------------------------
def loaded_urls(page) -> list[str]:
    return page.evaluate("performance.getEntriesByType('resource').map((e) => e.name)")


def test_without_a_tile_url_the_map_draws_the_offline_grid(open_page, demo):
    assert get(demo, "/web/config") == {"tiles": None}
    page, console = open_page("fleet")
    requests: list[str] = []
    page.on("request", lambda r: requests.append(r.url))
    page.wait_for_selector("#fleet-map[data-ready='1'] .leaflet-tile-container canvas.leaflet-tile")
    page.click("#fleet-map .leaflet-control-zoom-out")  # a new zoom level: new grid tiles
    page.wait_for_function(
        "document.querySelectorAll('#fleet-map canvas.leaflet-tile').length >= 4", timeout=10_000
    )
    assert page.locator("#fleet-map img.leaflet-tile").count() == 0
    # The grid: a light fill with a line every 64 px.
    fill, line = page.evaluate(
        """() => {
             const g = document.querySelector('#fleet-map canvas.leaflet-tile').getContext('2d');
             return [[10, 10], [64, 10]].map(([x, y]) => [...g.getImageData(x, y, 1, 1).data]);
           }"""
    )
    assert fill == [244, 246, 248, 255] and line == [221, 226, 231, 255], (fill, line)
    hosts = {urlsplit(u).hostname for u in [*loaded_urls(page), *requests]}
    assert hosts <= LOOPBACK, f"requests left the machine: {hosts}"
    console.assert_clean()


def png(width: int = 256, height: int = 256, rgb: tuple[int, int, int] = (170, 211, 223)) -> bytes:
    """A plain PNG: signature, IHDR, one zlib IDAT of filter-0 rows, IEND."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (
            struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
        )

    rows = b"".join(b"\0" + bytes(rgb) * width for _ in range(height))
    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)  # 8-bit RGB
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"IDAT", zlib.compress(rows))
        + chunk(b"IEND", b"")
    )


class TileServer:
    """A loopback HTTP server answering every GET with one PNG; it keeps the paths asked for."""

    def __init__(self) -> None:
        self.paths: list[str] = []
        body, paths = png(), self.paths

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self) -> None:
                paths.append(self.path)
                self.send_response(200)
                self.send_header("Content-Type", "image/png")
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, *args) -> None:
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}"
        threading.Thread(target=self.server.serve_forever, daemon=True).start()

    def close(self) -> None:
        self.server.shutdown()
        self.server.server_close()


def tile_of(lat: float, lon: float, z: int) -> tuple[int, int]:
    """The slippy-map tile (x, y) holding lat, lon at zoom z."""
    n = 2**z
    x = int((lon + 180) / 360 * n)
    y = int((1 - math.asinh(math.tan(math.radians(lat))) / math.pi) / 2 * n)
    return x, y


def test_with_a_tile_url_the_map_loads_tiles_from_it(open_page, tmp_path):
    tiles = TileServer()
    template = f"{tiles.url}/{{z}}/{{x}}/{{y}}.png"
    server = start_demo(tmp_path, "--drones", "1", "--tiles", template)
    try:
        assert get(server, "/web/config") == {"tiles": template}
        page, console = open_page("fleet", server=server)
        page.wait_for_selector("#fleet-map img.leaflet-tile-loaded", timeout=20_000)
        page.wait_for_selector("#fleet-table tr[data-drone='QUAD_1']")
        where = get(server, "/drones/QUAD_1")["position"]
        asked = [re.fullmatch(r"/(\d+)/(\d+)/(\d+)\.png", p) for p in list(tiles.paths)]
        assert asked and all(asked), f"not /z/x/y.png: {tiles.paths}"
        found = {tuple(int(v) for v in m.groups()) for m in asked}
        assert all(z <= 19 for z, _, _ in found), found  # maxNativeZoom: no deeper
        assert any((z, *tile_of(where["lat"], where["lon"], z)) in found for z, _, _ in found), (
            f"no tile under the drone at {where}: {sorted(found)}"
        )
        # The offline grid stays underneath; nothing but loopback was asked.
        assert page.locator("#fleet-map canvas.leaflet-tile").count() > 0
        assert {urlsplit(u).hostname for u in loaded_urls(page)} <= LOOPBACK
        console.assert_clean()
    finally:
        server.stop()
        tiles.close()


# -- 5. Restart ------------------------------------------------------------------------------------
def test_the_fleet_page_recovers_by_itself_when_the_server_restarts(open_page, tmp_path):
    port = free_port()
    first = start_demo(tmp_path, "--drones", "1", port=port, log="first.log")
    token = first.operator  # kept in the state dir: the restarted demo prints the same one
    try:
        assert first.url == f"http://127.0.0.1:{port}"
        page, console = open_page("fleet", server=first)
        page.wait_for_selector("#fleet-table tr[data-drone='QUAD_1'][data-status='online']")
        page.evaluate("window.notReloaded = true")
        console.assert_clean()
    finally:
        first.stop()
    page.wait_for_function(
        "document.getElementById('link-state').dataset.state !== 'live'", timeout=20_000
    )
    assert page.get_attribute("#link-state", "data-state") == "reconnecting"
    assert page.locator("#fleet-table tr[data-drone='QUAD_2']").count() == 0

    # Same port and state dir; a second drone only this server has.
    second = start_demo(tmp_path, "--drones", "2", port=port, log="second.log")
    try:
        assert second.url == first.url and second.operator == token
        assert get(second, "/web/me", token=token)["role"] == "operator"
        page.wait_for_selector("#link-state[data-state='live']", timeout=45_000)
        page.wait_for_selector(
            "#fleet-table tr[data-drone='QUAD_2'][data-status='online']", timeout=30_000
        )
        page.wait_for_selector("#fleet-table tr[data-drone='QUAD_1'][data-status='online']")
        assert page.evaluate("window.notReloaded === true"), "the page was reloaded"
        assert not page.locator("#login").is_visible(), "the page asked for a token again"
        down = [e for e in console.errors if not CONNECTION_LOST.search(e)]
        assert not down, f"errors besides the lost connection: {down}"
        console.errors.clear()
        page.wait_for_function(  # the stream's heartbeats update the table again
            """() => [...document.querySelectorAll('#fleet-table tbody tr td:last-child')]
                      .every((td) => /^[0-2] s ago$/.test(td.textContent))""",
            timeout=20_000,
        )
        console.assert_clean()
    finally:
        second.stop()


def test_the_tokens_a_demo_printed_still_work_after_it_restarts(tmp_path):
    first = start_demo(tmp_path, "--drones", "1", log="first.log")
    first.stop()
    second = start_demo(tmp_path, "--drones", "1", log="second.log")
    try:
        for role, token in (("operator", first.operator), ("viewer", first.viewer)):
            try:
                me = get(second, "/web/me", token=token)
            except urllib.error.HTTPError as exc:
                raise AssertionError(f"the first {role} token is refused: {exc.code}") from exc
            assert me["role"] == role
    finally:
        second.stop()


# -- 7. Alarms ------------------------------------------------------------------------------------
def test_an_alarm_shows_on_the_fleet_page_as_it_comes(open_page, demo, screenshot):
    page, console = open_page("fleet")
    row = "#fleet-table tr[data-drone='QUAD_1']"
    page.wait_for_selector(row)
    assert page.get_attribute(row, "data-alarm") == ""
    alarm = {"command": "virtualalarm", "level": "OUT_MEASURE", "message": "CO2 above bounds"}
    assert post(demo, "/drones/QUAD_1/mission", {"steps": [alarm]}) == 200
    page.wait_for_selector(f"{row}[data-alarm='OUT_MEASURE']", timeout=20_000)
    assert "OUT_MEASURE CO2 above bounds" in page.inner_text(f"{row} td.alarm")
    toast = page.locator(".toast.error", has_text="alarm from QUAD_1")
    assert toast.count() == 1 and "CO2 above bounds" in toast.inner_text()
    screenshot(page, "7-fleet-alarm")
    console.assert_clean()


# -- 8. Handovers on the planner's map -------------------------------------------------------------
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
    label = page.locator(".handover-label")
    assert label.count() == 1
    taker = re.fullmatch(r"handover: QUAD_1 → (QUAD_\d) \(on alarm\)", label.inner_text())
    assert taker and taker.group(1) != "QUAD_1", label.inner_text()
    assert "4/4 waypoints" in page.inner_text("#mission-status")
    screenshot(page, "8-planner-handover")
    console.assert_clean()


# -- 6. Phone and desktop --------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("width", "height", "phone"), [(390, 844, True), (1280, 860, False)], ids=["phone", "desktop"]
)
def test_the_fleet_page_fits_the_screen_and_the_nav_works(open_page, width, height, phone):
    page, console = open_page(
        "fleet", viewport={"width": width, "height": height}, is_mobile=phone, has_touch=phone
    )
    page.wait_for_selector("#fleet-table tbody tr")  # the table, the widest part, is filled

    def no_sideways_scroll() -> None:
        scroll, client = page.evaluate(
            "[document.documentElement.scrollWidth, document.documentElement.clientWidth]"
        )
        assert scroll <= client, f"the page scrolls sideways: {scroll} > {client} px"

    no_sideways_scroll()
    for link in page.locator("nav a").all():
        box = link.bounding_box()
        assert box and box["x"] >= 0 and box["x"] + box["width"] <= width, link.inner_text()
        assert box["height"] >= 24 and box["width"] >= 24, f"too small to tap: {link.inner_text()}"
    nav = page.locator("nav a[data-page='control']")
    nav.tap() if phone else nav.click()
    page.wait_for_selector("#control-map[data-ready='1']")
    assert page.inner_text("#page h1") == "Control"
    assert nav.get_attribute("aria-current") == "page"
    assert page.locator("nav a[data-page='fleet']").get_attribute("aria-current") is None
    no_sideways_scroll()
    console.assert_clean()
