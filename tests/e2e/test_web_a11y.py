"""Every page accessible, alarms readable and audible (issue 14), in Chromium on the demo.

axe-core (npm, a devDependency; never served by the app) runs on each page at a desktop and a
phone size and must find no serious or critical violation. An alarm toast's text contrast is
computed from its rendered colours with the WCAG formula. A CRITICAL alarm beeps once the
operator has touched the page, stays silent (and the console clean) before that, and not at all
when muted. Screenshots of every page at both sizes go to test-artifacts/e2e/.
"""

from __future__ import annotations

import json
import time

import pytest
from playwright.sync_api import expect

from .a11y import blocking, contrast_ratio, describe, run_axe
from .conftest import ARTIFACTS, post_for

pytestmark = pytest.mark.e2e

PAGES = ["fleet", "control", "planner", "telemetry", "replay", "call"]
SIZES = {"desktop": {"width": 1280, "height": 860}, "phone": {"width": 390, "height": 844}}
#: WCAG 2.x AA for normal text.
AA_CONTRAST = 4.5


@pytest.mark.parametrize("size", SIZES)
def test_every_page_has_no_serious_accessibility_violation(open_page, screenshot, size):
    found: dict[str, list] = {}
    for name in PAGES:
        page, console = open_page(name, viewport=SIZES[size])
        if name in ("fleet", "control", "planner"):  # the map has placed the drones
            page.wait_for_selector(".drone-label")
        violations = run_axe(page)
        found[name] = violations
        screenshot(page, f"page-{name}-{size}")
        console.assert_clean()
        page.context.close()
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    (ARTIFACTS / f"axe-{size}.json").write_text(json.dumps(found, indent=1))
    bad = {name: blocking(v) for name, v in found.items() if blocking(v)}
    assert not bad, "\n".join(f"{name}:\n{describe(v)}" for name, v in bad.items())


def test_the_selected_drones_panel_and_the_sign_in_have_no_serious_violation(
    open_page, browser, demo
):
    page, console = open_page("fleet")
    page.click("#fleet-table button.select[data-drone='QUAD_1']")
    expect(page.locator("#fleet-panel [data-figure='battery']")).to_contain_text("%")
    found = blocking(run_axe(page))
    assert not found, describe(found)
    console.assert_clean()
    # The sign-in dialog, as an operator without a token sees it.
    context = browser.new_context(viewport=SIZES["phone"])
    try:
        fresh = context.new_page()
        fresh.goto(demo.url)
        fresh.wait_for_selector("#login[open]")
        found = blocking(run_axe(fresh))
        assert not found, describe(found)
    finally:
        context.close()


def raise_alarm(demo, drone: str, message: str) -> None:
    """The seed's virtual alarm, from a one-step mission sent to the drone itself (not through
    the planner, which would replace the drone on a CRITICAL alarm)."""
    step = {"command": "virtualalarm", "level": "CRITICAL", "message": message}
    for _ in range(60):  # the drone may still be busy with an earlier test's mission
        status, answer = post_for(demo, f"/drones/{drone}/mission", {"steps": [step]})
        if status == 200:
            return
        time.sleep(1.0)
    pytest.fail(f"{drone} did not take the alarm mission: {status} {answer!r}")


def test_a_critical_alarm_toast_is_readable_and_beeps_after_a_gesture_unless_muted(
    open_page, demo, screenshot
):
    page, console = open_page("fleet")
    warnings: list[str] = []
    page.on("console", lambda m: m.type == "warning" and warnings.append(m.text))
    mute = page.locator("#mute")
    expect(mute).to_have_attribute("data-audio", "waiting")
    # Before any click or key press: shown, not played, and the browser has nothing to refuse.
    raise_alarm(demo, "QUAD_3", "smoke before a gesture")
    toast = page.locator(".toast.error", has_text="smoke before a gesture")
    expect(toast).to_contain_text("alarm from QUAD_3: CRITICAL smoke before a gesture")
    assert mute.get_attribute("data-beeps") == "0"
    fg, bg = toast.evaluate("t => [getComputedStyle(t).color, getComputedStyle(t).backgroundColor]")
    ratio = contrast_ratio(fg, bg)
    print(f"alarm toast: {fg} on {bg}, contrast {ratio:.2f}:1")
    assert ratio >= AA_CONTRAST, (fg, bg, ratio)
    screenshot(page, "alarm-toast")
    # The operator clicks the page once: sound is allowed from then on.
    page.click("h1")
    expect(mute).to_have_attribute("data-audio", "ready")
    raise_alarm(demo, "QUAD_3", "smoke after a gesture")
    expect(page.locator(".toast.error", has_text="smoke after a gesture")).to_be_visible()
    expect(mute).to_have_attribute("data-beeps", "1")
    assert page.evaluate("document.getElementById('mute').getAttribute('aria-pressed')") == "false"
    # Muted: still shown, never sounded; the choice is kept across reloads.
    mute.click()
    expect(mute).to_have_attribute("aria-pressed", "true")
    expect(mute).to_have_text("Alarm sound: off")
    raise_alarm(demo, "QUAD_3", "smoke while muted")
    expect(page.locator(".toast.error", has_text="smoke while muted")).to_be_visible()
    assert mute.get_attribute("data-beeps") == "1"
    page.reload()
    page.wait_for_selector("#page[data-mounted='fleet']")
    expect(page.locator("#mute")).to_have_attribute("aria-pressed", "true")
    console.assert_clean()
    assert not [w for w in warnings if "AudioContext" in w or "autoplay" in w.lower()], warnings
