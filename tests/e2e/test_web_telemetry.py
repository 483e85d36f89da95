"""The Telemetry page's live mode: the chart keeps growing with nothing pressed."""

from __future__ import annotations

import pytest

pytestmark = pytest.mark.e2e


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
