"""The Control page end to end: the seed's commands as buttons, on QUAD_2 (test_web_apps.py flies
QUAD_1 and calls QUAD_3): answers and state, a clicked point, confirmations, refused and forced
disarm. The test brings QUAD_2 down again.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable

import pytest

from .conftest import M_PER_DEG, get, post

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
        before = len(sent)
        page.mouse.click(x, y)  # asked first (how far, how high); dismissed, nothing is sent
        assert dialogs[-1].startswith(f"Fly {DRONE} to ") and " m away)?" in dialogs[-1], dialogs
        page.wait_for_timeout(300)
        assert sent[before:] == []
        reply["accept"] = True
        _, answer = command(page, "navigate", lambda: page.mouse.click(x, y))
        reply["accept"] = False
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
