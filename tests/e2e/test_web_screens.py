"""Every page of the web app, on a laptop (1280x800) and on a phone (390x844), as screenshots in
``test-artifacts/e2e/`` (issue 29): ``page-NAME-WxH.png``, the whole page.

Each page mounts with no console error, is no wider than the screen (nothing to scroll
sideways on a phone), and a map on it is ready before the picture is taken.
"""

from __future__ import annotations

import pytest

from .conftest import ARTIFACTS, Console

pytestmark = pytest.mark.e2e
PAGES = ["fleet", "control", "planner", "telemetry", "replay", "photos", "call"]
SIZES = [(1280, 800), (390, 844)]


@pytest.mark.parametrize(("width", "height"), SIZES, ids=["laptop", "phone"])
def test_every_page_is_photographed_and_fits_the_screen(browser, demo, width, height):
    context = browser.new_context(viewport={"width": width, "height": height})
    try:
        page = context.new_page()
        console = Console(page)
        page.goto(f"{demo.url}/?token={demo.operator}#/fleet")
        page.wait_for_selector("#link-state[data-state='live']", timeout=15_000)
        ARTIFACTS.mkdir(parents=True, exist_ok=True)
        wide = {}
        for name in PAGES:
            page.goto(f"{demo.url}/#/{name}")
            page.wait_for_selector(f"#page[data-mounted='{name}']", timeout=15_000)
            if page.locator("#page .map").count():
                page.wait_for_selector("#page .map[data-ready='1']", timeout=15_000)
            page.wait_for_timeout(500)  # the first stream messages fill the tables
            sideways = page.evaluate("document.documentElement.scrollWidth") - width
            if sideways > 0:
                wide[name] = sideways
            page.screenshot(
                path=str(ARTIFACTS / f"page-{name}-{width}x{height}.png"), full_page=True
            )
        page.goto(f"{demo.url}/docs")
        page.wait_for_selector(".opblock", timeout=20_000)
        page.screenshot(path=str(ARTIFACTS / f"page-docs-{width}x{height}.png"), full_page=True)
        assert wide == {}, f"pages wider than the screen (px): {wide}"
        console.assert_clean()
        shots = sorted(p.name for p in ARTIFACTS.glob(f"page-*-{width}x{height}.png"))
        assert len(shots) == len(PAGES) + 1, shots
    finally:
        context.close()
