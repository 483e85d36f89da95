"""The maps' search box (issue 14): coordinates (decimal, DMS), a drone, a mission, an address
(through a geocoder the ground asks: a small Nominatim-compatible server of the test's own)."""

from __future__ import annotations

import json

import pytest

from support.nominatim import Nominatim

from .conftest import get, post_for, start_demo

pytestmark = pytest.mark.e2e


def search(page, box: str, text: str, state: str = "found") -> str:
    """Type `text` in the search box of map `box`, press Enter; the status line it shows."""
    form = f"{box} form.map-search"
    page.fill(f"{form} input", text)
    page.press(f"{form} input", "Enter")
    page.wait_for_selector(f"{form}[data-state='{state}']", timeout=15_000)
    return page.inner_text(f"{form} .map-search-status")


def centred(page, box: str) -> tuple[float, float]:
    """How far (px) the search marker is from the middle of map `box`: (0, 0) = centred on it."""
    page.wait_for_timeout(400)  # Leaflet's pan/zoom animation (0.25 s) ends
    area = page.locator(box).bounding_box()
    mark = page.locator(f"{box} path.search-marker").bounding_box()
    return (
        mark["x"] + mark["width"] / 2 - (area["x"] + area["width"] / 2),
        mark["y"] + mark["height"] / 2 - (area["y"] + area["height"] / 2),
    )


def near_zero(offset: tuple[float, float]) -> bool:
    return abs(offset[0]) <= 2 and abs(offset[1]) <= 2


def test_the_fleet_map_centres_on_coordinates_a_drone_and_a_mission(open_page, demo):
    page, console = open_page("fleet")
    box = "#fleet-map"
    page.wait_for_selector(f"{box} .drone-marker")  # the page fits the map to its drones
    assert search(page, box, "40°37'48\"N 8°39'36\"W") == "40.630000, -8.660000"
    assert near_zero(centred(page, box)), centred(page, box)
    assert search(page, box, "40.6312, -8.6601") == "40.631200, -8.660100"
    assert near_zero(centred(page, box))

    # A drone: where it is now (the fleet's table says the same).
    where = get(demo, "/drones/QUAD_2")["position"]
    assert search(page, box, "quad_2") == "drone QUAD_2"
    assert near_zero(centred(page, box))
    assert page.get_attribute(f"{box} form.map-search", "data-kind") == "drone"
    assert abs(where["lat"] - 40.63) < 0.001

    # A mission by its name: the map fits its area.
    lat, lon = 40.6315, -8.6575
    steps = [{"command": "navigate", "lat": lat, "lon": lon, "altitude_delta": 10}]
    status, answer = post_for(
        demo, "/missions", {"name": "Search orchard", "drones": ["QUAD_1"], "steps": steps}
    )
    assert status == 201, answer
    mission = json.loads(answer)["mission_id"]
    assert search(page, box, "orchard") == f"mission Search orchard ({mission})"
    assert near_zero(centred(page, box))

    # No geocoder: the box says how to get addresses; an impossible place says why.
    assert "--geocoder" in search(page, box, "Avenida da Universidade, Aveiro", "none")
    console.assert_clean()
    assert "latitude 91" in search(page, box, "91, 10", "error")
    # The refusal is a 422 with its reason, which the browser also logs: that, and only that.
    assert len(console.errors) == 1 and "status of 422" in console.errors[0], console.errors


def test_a_search_on_the_planner_map_adds_no_corner_and_the_control_page_has_one(open_page, demo):
    page, console = open_page("planner")
    page.wait_for_selector("#planner-map .drone-marker")
    search(page, "#planner-map", "40.6305, -8.6585")
    assert page.input_value("#plan-polygon") == ""  # the click on Find was not a map click
    page.goto(f"{demo.url}/#/control")
    page.wait_for_selector("#page[data-mounted='control']")
    assert search(page, "#control-map", "QUAD_1") == "drone QUAD_1"
    console.assert_clean()


def test_an_address_is_found_through_the_grounds_geocoder(open_page, tmp_path):
    geocoder = Nominatim()
    server = start_demo(tmp_path, "--drones", "1", "--geocoder", geocoder.url)
    try:
        page, console = open_page("fleet", server=server)
        box = "#fleet-map"
        page.wait_for_selector(f"{box} .drone-marker")
        label = search(page, box, "Rua de Aveiro 10")
        assert label == "Rua de Aveiro 10, Aveiro, Portugal"
        assert near_zero(centred(page, box))
        assert len(geocoder.asked) == 1  # asked by the ground, once; the page only asked it
        assert search(page, box, "40.63, -8.66").startswith("40.63")
        assert len(geocoder.asked) == 1  # coordinates never leave the ground
        console.assert_clean()
    finally:
        server.stop()
        geocoder.close()
