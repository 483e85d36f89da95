"""The Fleet page: alarms as they come, and a layout that fits a phone and a desktop."""

from __future__ import annotations

import pytest

from .conftest import post

pytestmark = pytest.mark.e2e


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
    colours = toast.evaluate(
        "t => [getComputedStyle(t).color, getComputedStyle(t).backgroundColor]"
    )
    assert colours[0] != colours[1], f"the alarm is unreadable: {colours}"  # text on its own red
    screenshot(page, "7-fleet-alarm")
    console.assert_clean()


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
