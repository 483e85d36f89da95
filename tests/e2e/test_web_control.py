"""The Control page end to end: the seed's commands as buttons, on QUAD_2 (test_web_apps.py flies
QUAD_1 and calls QUAD_3): answers and state, a clicked point, confirmations, refused and forced
disarm. The test brings QUAD_2 down again.
"""

from __future__ import annotations

import json
import math
import re
import time
from collections.abc import Callable

import pytest

from .conftest import M_PER_DEG, get, post, post_for

pytestmark = pytest.mark.e2e

DRONE = "QUAD_2"
REFUSED = "Failed to load resource: the server responded with a status of 409 (Conflict)"


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


def hovering(demo, timeout_s: float = 30) -> dict:
    """QUAD_2's position once the ground's picture of it has stopped moving (five reads over
    1.2 s within 0.5 m): right after a move is done the REST position can be a few telemetry
    samples behind, a couple of metres of a climb at the demo's speed-up on a loaded host (CI
    read 9.25 m above home for a drone the take-off had just brought to 12)."""
    reads = [get(demo, f"/drones/{DRONE}")["position"]]
    deadline = time.monotonic() + timeout_s
    while True:
        time.sleep(0.3)
        reads = [*reads[-4:], get(demo, f"/drones/{DRONE}")["position"]]
        first, now = reads[0], reads[-1]
        north, east = offset_m(first, now)
        # Over 1.2 s: longer than a heartbeat period at the demo's speed-up (1 wall s).
        if len(reads) == 5 and math.hypot(north, east, now["alt_m"] - first["alt_m"]) < 0.5:
            return now
        if time.monotonic() > deadline:
            pytest.fail(f"{DRONE} never settled: {reads}")


FINAL = ("done", "failed", "refused", "superseded")


def command(page, name: str, act: Callable[[], None], expect: str = "done", where: str = "control"):
    """Do `act` (press a button, click the map); wait until the page says how it ended.

    `where`: "control" (the page's result) or "panel" (the drone panel's). Returns (the
    result's words, the ground's answer as JSON). The words are never raw JSON (issue 29)."""
    box = "#control-result" if where == "control" else "#control-panel-result"
    path = f"/commands/{name}"
    with page.expect_response(lambda r: path in r.url and r.request.method == "POST") as sent:
        act()
    answer = sent.value.json()
    final = ", ".join(f"{box}[data-command='{name}'][data-state='{s}']" for s in FINAL)
    page.wait_for_selector(final, timeout=60_000)
    text, state = page.inner_text(box), page.get_attribute(box, "data-state")
    assert state == expect, f"{name}: expected {expect}, the page shows {text!r}"
    assert "{" not in text and "alt_m" not in text, f"raw JSON on the page: {text!r}"
    return text, answer


def now_above_home_m(text: str) -> float:
    """The height a done move ended at, as the page says it ("now 12 m above home")."""
    found = re.search(r"now ([0-9.]+) m above home", text)
    assert found, f"no height in {text!r}"
    return float(found.group(1))


def watch_states(page, box: str = "#control-result") -> None:
    """Record every state the result box goes through (window.states), to see "accepted"
    come before "done"."""
    page.evaluate(
        """(box) => {
             window.states = [];
             const node = document.querySelector(box);
             new MutationObserver(() => window.states.push(node.dataset.state))
               .observe(node, { attributes: true, attributeFilter: ["data-state"] });
           }""",
        box,
    )


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

    def pad(direction: str) -> Callable[[], None]:
        return lambda: page.click(f"button.move[data-move='{direction}']")

    try:
        # Arm, then take off to 12 m: said in words with the frame; "done" only once it is up.
        text, answer = command(page, "arm", press("arm"))
        assert answer["ok"] is True and answer["drone_id"] == DRONE
        assert text == f"{DRONE}: arm the motors: done."
        wait_for_drone(demo, "armed", lambda d: d["state"] == "armed")
        wait_for_option(page, "armed")
        page.fill("#control-altitude", "12")
        watch_states(page)
        text, answer = command(page, "takeoff", press("takeoff"))
        assert answer["done"] is False  # accepted: the climb has only started
        assert answer["result"]["target"]["alt_m"] == pytest.approx(start["home"]["alt_m"] + 12)
        assert text.startswith(f"{DRONE}: take-off to 12 m above home: done, reached"), text
        assert page.evaluate("window.states") == ["sending", "accepted", "done"]
        assert now_above_home_m(text) == pytest.approx(12, abs=2.0), ("done before up", text)
        wait_for_option(page, "flying")

        # Moves any way by the 5 m step: north, west, down, up, each done where the drone is.
        moves = {"north": (5, 0, 0), "west": (0, -5, 0), "down": (0, 0, -5), "up": (0, 0, 5)}
        names = {"north": "changeN", "west": "changeE", "down": "altitude", "up": "altitude"}
        words = {"north": "move 5 m north", "west": "move 5 m west", "down": "descend 5 m"}
        for direction, (north, east, up_m) in moves.items():
            here = hovering(demo)
            text, answer = command(page, names[direction], pad(direction))
            target = answer["result"]["target"]
            assert offset_m(here, target) == pytest.approx((north, east), abs=1.5), direction
            assert target["alt_m"] - here["alt_m"] == pytest.approx(up_m, abs=1.5), direction
            assert text.startswith(f"{DRONE}: {words.get(direction, 'climb 5 m')}: done"), text
            # "Above home" is above the home the drone reports (the autopilot's, set where it
            # armed), as in its own words, not the REST position's relative_alt_m.
            home_alt_m = get(demo, f"/drones/{DRONE}")["home"]["alt_m"]
            height_m = here["alt_m"] - home_alt_m + up_m
            assert now_above_home_m(text) == pytest.approx(height_m, abs=2.0), text

            def arrived(d, here=here, north=north, east=east, up=up_m) -> bool:
                n, e = offset_m(here, d["position"])
                climb = d["position"]["alt_m"] - here["alt_m"]
                return math.dist((n, e, climb), (north, east, up)) < 1.5

            wait_for_drone(demo, f"moved ({direction})", arrived)  # heartbeats follow

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
        before = len(sent)
        page.mouse.click(x, y)  # asked first (how far, how high); dismissed, nothing is sent
        assert dialogs[-1].startswith(f"{DRONE}: fly to "), dialogs
        assert " at 12 m above home (" in dialogs[-1] and " m away)?" in dialogs[-1], dialogs
        page.wait_for_timeout(300)
        assert sent[before:] == []
        reply["accept"] = True
        text, answer = command(page, "navigate", lambda: page.mouse.click(x, y))
        reply["accept"] = False
        target = answer["result"]["target"]
        m_per_px = 156_543.03 * math.cos(math.radians(here["lat"])) / 2**19
        assert offset_m(here, target) == pytest.approx((50 * m_per_px, 70 * m_per_px), abs=3.0)
        assert target["alt_m"] == pytest.approx(start["home"]["alt_m"] + 12)  # "the altitude above"
        assert "at 12 m above home: done, reached" in text, text
        assert now_above_home_m(text) == pytest.approx(12, abs=2.0), text
        wait_for_drone(
            demo,
            "reached the clicked point",
            lambda d: math.dist(offset_m(target, d["position"]), (0, 0)) < 2,
        )
        screenshot(page, "6-control-flying")

        # Destructive commands ask first; dismissed, nothing is sent.
        for name, label in (("disarm", "Disarm"), ("resetfc", "Reset")):
            before = len(sent)
            page.click(f"button.command[data-command='{name}']")
            assert dialogs and dialogs[-1].startswith(f"{label} {DRONE}?"), dialogs
            page.wait_for_timeout(300)  # a request would have left by now
            assert sent[before:] == [], f"{name} was sent although the dialog was dismissed"
            assert page.get_attribute("#control-result", "data-command") == "navigate"
        before = len(sent)
        page.click("#control-panel-land")
        assert dialogs[-1].startswith(f"{DRONE}: land where it is?"), dialogs
        page.wait_for_timeout(300)
        assert sent[before:] == [], "land was sent although the dialog was dismissed"

        # Accepted: sent. Disarming in flight is refused (not forced) and the page says why.
        reply["accept"] = True
        text, _ = command(page, "disarm", press("disarm"), expect="refused")
        assert sent[-1] == "disarm"
        assert "refused disarm" in text and "land first" in text, text
        assert get(demo, f"/drones/{DRONE}")["state"] == "flying"
        screenshot(page, "6-control-disarm-refused")

        # A mission flies it: a move is refused in the drone's own sentence; Hold is obeyed
        # (the mission pauses) and is done when the drone holds still.
        status, body = post_for(
            demo, f"/drones/{DRONE}/mission", {"steps": [{"command": "sleep", "value": 600}]}
        )
        assert status == 200, body
        text, _ = command(page, "changeN", pad("north"), expect="refused")
        assert f"{DRONE} is flying mission " in text and "pause or abort it first" in text, text
        text, answer = command(
            page, "mode", lambda: page.click("#control-panel-hold"), where="panel"
        )
        assert answer["result"]["mode"] == "HOLD", answer
        assert text.startswith(f"{DRONE}: stop and hold position (HOLD): done, holding still"), text
        assert post(demo, f"/drones/{DRONE}/mission/stop") == 200
        # The mode selector: GUIDED (no mission now), then Land from the panel.
        page.select_option("#control-panel-mode-select", "GUIDED")
        text, _ = command(
            page, "mode", lambda: page.click("#control-panel-set-mode"), where="panel"
        )
        assert "fly on to its goal (GUIDED): done, reached" in text, text
        screenshot(page, "6-control-modes")
        text, answer = command(
            page, "land", lambda: page.click("#control-panel-land"), where="panel"
        )
        assert sent[-1] == "land" and answer["ok"] is True
        assert text.startswith(f"{DRONE}: land where it is: done, landed"), text
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
        page.check("#control-force")
        text, answer = command(page, "disarm", press("disarm"))
        assert dialogs[-1].startswith(f"Force disarm {DRONE}?"), dialogs
        assert answer["ok"] is True and json.loads(bodies[-1]) == {"force": True}, bodies
        assert "disarm (forced: in the air it falls): done" in text, text
        wait_for_drone(
            demo,
            "fallen and disarmed",
            lambda d: d["state"] == "disarmed" and d["position"]["relative_alt_m"] < 0.5,
            timeout_s=60,
        )
        page.uncheck("#control-force")
    finally:
        post(demo, f"/drones/{DRONE}/mission/stop")
        if get(demo, f"/drones/{DRONE}")["position"]["relative_alt_m"] > 0.5:
            post(demo, f"/drones/{DRONE}/commands/land")  # never leave it flying
    for refusal in (REFUSED, REFUSED):  # the refused disarm and move, sent on purpose
        console.errors.remove(refusal)
    console.assert_clean()
