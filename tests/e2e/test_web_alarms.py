"""Issue 29, item 5: the alarm centre. A drone's alarms ring the bell on every page, are listed
(open ones first) and acknowledged by the signed-in operator; a reload and a ground restart keep
them, who acknowledged them, and each drone's "Last alarm"."""

from __future__ import annotations

import pytest
from playwright.sync_api import expect

from .conftest import free_port, get, post_for, start_demo

pytestmark = pytest.mark.e2e

STEPS = [
    {"command": "virtualalarm", "level": "CRITICAL", "message": "battery 15 % (test)"},
    {"command": "virtualalarm", "level": "WARNING", "message": "gusts 12 m/s (test)"},
]


def test_alarms_ring_the_bell_are_acknowledged_and_kept_across_reload_and_restart(
    open_page, tmp_path, screenshot
):
    port = free_port()
    first = start_demo(tmp_path, "--drones", "1", port=port, log="first.log")
    token = first.operator
    try:
        page, console = open_page("fleet", server=first)
        page.wait_for_selector("#fleet-table tr[data-drone='QUAD_1'][data-status='online']")
        expect(page.locator("#alarm-count")).to_have_text("0")
        status, body = post_for(first, "/drones/QUAD_1/mission", {"steps": STEPS})
        assert status == 200, body
        bell = page.locator("#alarms-bell")
        expect(page.locator("#alarm-count")).to_have_text("2", timeout=20_000)
        expect(bell).to_have_attribute("aria-label", "Alarms: 2 not acknowledged")

        # The bell is on every page: open it from the Control page.
        page.click("nav a[data-page='control']")
        page.wait_for_selector("#page[data-mounted='control']")
        bell.click()
        expect(bell).to_have_attribute("aria-expanded", "true")
        items = page.locator("#alarm-list > li")
        expect(items).to_have_count(2)
        expect(items.nth(0)).to_contain_text("Warning · QUAD_1")
        expect(items.nth(0)).to_contain_text("gusts 12 m/s (test)")
        expect(items.nth(1)).to_contain_text("Critical · QUAD_1")
        critical = page.locator("#alarm-list > li[data-level='CRITICAL']")
        with page.expect_response(lambda r: r.url.endswith("/ack")) as acked:
            critical.locator("button.ack").click()
        assert acked.value.status == 200, acked.value.text()
        expect(page.locator("#alarm-count")).to_have_text("1")
        # The open one first, then the acknowledged one, saying who did it.
        expect(items.nth(0)).to_have_attribute("data-level", "WARNING")
        expect(items.nth(1)).to_have_attribute("data-acked", "true")
        expect(items.nth(1)).to_contain_text("Acknowledged by operator at")
        screenshot(page, "alarms-centre")
        audit = get(first, "/audit?limit=20")
        assert [a["who"] for a in audit if a["command"] == "ack_alarm"] == ["operator"]

        # A reload: the count, the list and the drone's "Last alarm" come back from the API.
        page.click("nav a[data-page='fleet']")
        page.reload()
        page.wait_for_selector("#page[data-mounted='fleet']")
        expect(bell).to_have_attribute("aria-expanded", "false")
        expect(page.locator("#alarm-count")).to_have_text("1")
        row = page.locator("#fleet-table tr[data-drone='QUAD_1']")
        expect(row).to_have_attribute("data-alarm", "WARNING", timeout=15_000)
        expect(row).to_contain_text("gusts 12 m/s (test)")
        row.locator("button.select").click()
        last = page.locator("#fleet-panel dd[data-figure='alarm']")
        expect(last).to_contain_text("Warning: gusts 12 m/s (test)")
        console.assert_clean()

        # A viewer sees the open alarm but has no button to acknowledge it.
        # On a phone (390 x 844): the bell and its panel fit the screen.
        phone = {"width": 390, "height": 844}
        watcher, watcher_console = open_page(
            "fleet", server=first, token=first.viewer, viewport=phone
        )
        watcher.click("#alarms-bell")
        open_one = watcher.locator("#alarm-list > li[data-acked='false']")
        expect(open_one).to_contain_text("Not acknowledged")
        box = watcher.locator("#alarm-centre").bounding_box()
        assert box["x"] >= 0 and box["x"] + box["width"] <= phone["width"], box
        screenshot(watcher, "alarms-centre-phone")
        assert open_one.locator("button.ack").count() == 0
        # Nor may a viewer fly it: the panel's mode selector, Hold and Land stay disabled.
        watcher.click("#alarm-close")
        watcher.click("#fleet-table button.select[data-drone='QUAD_1']")
        watcher.wait_for_selector("#fleet-panel[data-drone='QUAD_1'] [data-figure='battery']")
        for control in ("mode-select", "set-mode", "hold", "land"):
            assert watcher.locator(f"#fleet-panel-{control}").is_disabled(), control
        watcher_console.assert_clean()
    finally:
        first.stop()

    second = start_demo(tmp_path, "--drones", "1", port=port, log="second.log")
    try:
        page, console = open_page("fleet", server=second, token=token)
        expect(page.locator("#alarm-count")).to_have_text("1")
        page.click("#alarms-bell")
        items = page.locator("#alarm-list > li")
        expect(items).to_have_count(2)
        expect(items.nth(1)).to_contain_text("Acknowledged by operator at")
        console.assert_clean()
    finally:
        second.stop()
