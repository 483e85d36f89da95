"""What the Fleet and Control maps show of each drone (issue 29), in Chromium against the demo.

Each drone's home, in the drone's colour; names that never cover each other or another drone's
arrow at the default zoom (the demo's three drones start ten metres apart); a map without
imagery that says so on itself; and, while a mission flies, where the drone is going (its
leg's next waypoint) and the track it has flown.
"""

from __future__ import annotations

import json
import re
import time
from collections.abc import Iterator

import pytest

from .conftest import Demo, get, post_for, start_demo

pytestmark = pytest.mark.e2e
NO_TILES = "no map tiles: start the ground with --tiles FILE.mbtiles"
#: Label and arrow boxes on the map: [kind, drone, left, top, right, bottom].
BOXES = """sel => [...document.querySelectorAll(sel + ' .drone-marker')].flatMap(m => {
  const name = m.querySelector('.drone-label').textContent;
  return [['label', '.drone-label'], ['arrow', '.drone-icon']].map(([kind, part]) => {
    const r = m.querySelector(part).getBoundingClientRect();
    return [kind, name, r.left, r.top, r.right, r.bottom];
  });
})"""


def overlaps(boxes: list[list]) -> list[tuple[str, str]]:
    """Labels that cover another label or another drone's arrow."""
    found = []
    for kind, name, left, top, right, bottom in boxes:
        if kind != "label":
            continue
        for other_kind, other, l2, t2, r2, b2 in boxes:
            if other == name:
                continue
            if left < r2 and l2 < right and top < b2 and t2 < bottom:
                found.append((name, f"{other_kind} {other}"))
    return found


@pytest.fixture(scope="module")
def at_home(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Demo]:
    """A demo whose drones are where they started: the session's demo has its drones flown away
    by earlier tests (Control lands QUAD_2 metres off its home), so their names no longer meet."""
    demo = start_demo(tmp_path_factory.mktemp("markers"))
    yield demo
    demo.stop()


@pytest.mark.parametrize("name", ["fleet", "control"])
def test_each_drone_has_its_home_and_a_name_clear_of_the_others(open_page, at_home, name):
    demo = at_home
    page, console = open_page(name, server=demo)
    fleet = [d for d in get(demo, "/drones") if d.get("home")]
    assert len(fleet) >= 3
    selector = f"#{name}-map"
    page.wait_for_function(
        f"n => document.querySelectorAll('{selector} [data-kind=home]').length >= n", arg=len(fleet)
    )
    homes = page.locator(f"{selector} [data-kind=home]").evaluate_all(
        "els => els.map(e => [e.dataset.drone, e.querySelector('.map-badge').style.borderColor])"
    )
    assert {d for d, _ in homes} >= {d["drone_id"] for d in fleet}
    assert len({c for _, c in homes}) == len(homes), f"a colour per drone: {homes}"
    # The default zoom (19) puts the demo's drones ~50 px apart: their names would collide.
    page.wait_for_function(
        f"n => document.querySelectorAll('{selector} .drone-label').length >= n", arg=len(fleet)
    )
    page.wait_for_timeout(300)
    boxes = page.evaluate(BOXES, selector)
    assert len(boxes) >= 2 * len(fleet)
    assert overlaps(boxes) == [], (
        boxes,
        page.locator(f"{selector} .drone-label").evaluate_all(
            "els => els.map(e => [e.textContent, e.dataset.shift, e.style.transform])"
        ),
    )
    shifts = page.locator(f"{selector} .drone-label").evaluate_all(
        "els => els.map(e => Number(e.dataset.shift))"
    )
    assert any(shifts), "no label had to move: the drones are not as close as this test needs"
    # No imagery here: the map says how to get some.
    assert page.inner_text(f"{selector}-no-tiles") == NO_TILES
    console.assert_clean()


def test_a_flying_drone_shows_its_target_and_its_track(browser, tmp_path, screenshot):
    """Its own demo: a mission here would keep the shared demo's drones busy."""
    demo = start_demo(tmp_path, "--drones", "1")
    try:
        home = get(demo, "/drones")[0]["home"]
        lat, lon = home["lat"], home["lon"]
        square = [[lat + 0.0002, lon + 0.0002], [lat + 0.0002, lon + 0.0006]]
        square += [[lat - 0.0002, lon + 0.0006], [lat - 0.0002, lon + 0.0002]]
        body = {
            "drones": ["QUAD_1"],
            "area": {"polygon": square, "spacing_m": 10, "altitude_m": 15},
        }
        status, answer = post_for(demo, "/missions?start=true", body)
        assert status == 201, answer
        mission = json.loads(answer)["mission_id"]
        places = {
            (round(s["lat"], 7), round(s["lon"], 7))
            for s in get(demo, f"/missions/{mission}")["work"]
            if "lat" in s
        }
        context = browser.new_context(viewport={"width": 1280, "height": 800})
        page = context.new_page()
        page.goto(f"{demo.url}/?token={demo.operator}#/fleet")
        target = "#fleet-map [data-kind=target][data-drone=QUAD_1]"
        page.wait_for_selector(target, timeout=60_000)
        title = page.get_attribute(target, "title") or ""
        match = re.fullmatch(r"QUAD_1 going to (\S+), (\S+)", title)
        assert match, title
        assert (float(match.group(1)), float(match.group(2))) in places, (title, places)
        assert page.locator("#fleet-map path.drone-target-line").count() == 1
        # The track grows as the drone flies (the page keeps its positions).
        deadline = time.monotonic() + 60
        track = page.locator("#fleet-map path.drone-track")
        while len(re.findall(r"[LM]", track.get_attribute("d") or "")) < 3:
            assert time.monotonic() < deadline, track.get_attribute("d")
            page.wait_for_timeout(500)
        screenshot(page, "fleet-target-and-track")
        context.close()
    finally:
        demo.stop()
