"""A dropped mission log is untrusted input to the Replay page (issue 25 item 5).

Every text field of the log carries an HTML payload (``<img src=x onerror=...>``, ``<script>``).
Dropped on the page (a real drop event with the file, and the file input), each shows as text:
no element is built from it, nothing runs, and the console has no CSP violation (there is
nothing inline to refuse) nor a failed load of ``x``.
"""

from __future__ import annotations

import json

import pytest
from playwright.sync_api import expect

pytestmark = pytest.mark.e2e

IMG = '<img src=x onerror="window.__xss=1">'
SCRIPT = "<script>window.__xss=2</script>"
SVG = '<svg onload="window.__xss=3"></svg>'


def crafted_log() -> dict:
    path = [{"t": 0, "lat": 40.63, "lon": -8.659}, {"t": 10, "lat": 40.6304, "lon": -8.6586}]
    steps = [
        {"index": IMG, "command": SCRIPT, "started_s": 0, "duration_s": 5},
        {"index": 1, "command": SVG, "started_s": 5, "duration_s": 5},
    ]
    return {
        "mission_id": f"M{IMG}",
        "name": SCRIPT,
        "state": SVG,
        "steps_done": IMG,
        "steps_planned": 2,
        "handovers": [{"from_drone": IMG, "to_drone": SCRIPT}],
        "area": {"polygon": [[40.63, -8.659], [40.6305, -8.659], [40.6305, -8.6585]]},
        "drones": [
            {"drone_id": IMG, "path": path, "steps": steps},
            {"drone_id": SCRIPT, "path": path, "steps": []},
        ],
    }


#: Elements a payload would have made, anywhere in the document.
BUILT = """() => ({
  img: document.querySelectorAll('img[src="x"]').length,
  svg: document.querySelectorAll('svg[onload]').length,
  onerror: document.querySelectorAll('[onerror], [onload]').length,
  scripts: [...document.scripts].filter((s) => !s.src).length,
  xss: window.__xss === undefined ? null : window.__xss,
})"""


def _drop(page, text: str) -> None:
    """Drop a file holding ``text`` on the drop zone, as a person dragging it there would."""
    page.evaluate(
        """(text) => {
          const data = new DataTransfer();
          data.items.add(new File([text], 'crafted.json', { type: 'application/json' }));
          const zone = document.getElementById('replay-drop');
          const options = { dataTransfer: data, bubbles: true, cancelable: true };
          for (const type of ['dragover', 'drop']) zone.dispatchEvent(new DragEvent(type, options));
        }""",
        text,
    )


def _check_shown_as_text(page, console) -> None:
    title = page.locator("#replay-title")
    expect(title).to_contain_text(SCRIPT)  # the name, as text
    assert IMG in title.inner_text() and SVG in title.inner_text()
    tooltips = page.locator(".leaflet-tooltip").all_inner_texts()
    assert sorted(tooltips) == sorted([IMG, SCRIPT]), tooltips
    cells = page.locator("#replay-step-table tbody td").all_inner_texts()
    assert IMG in cells and SCRIPT in cells and SVG in cells, cells
    page.wait_for_timeout(500)  # a broken image's error, had one been made, would be in
    assert page.evaluate(BUILT) == {"img": 0, "svg": 0, "onerror": 0, "scripts": 0, "xss": None}
    console.assert_clean()


def test_a_dropped_log_full_of_html_shows_it_as_text(open_page, tmp_path):
    text = json.dumps(crafted_log())
    page, console = open_page("replay")
    _drop(page, text)
    _check_shown_as_text(page, console)

    page, console = open_page("replay")
    chosen = tmp_path / "crafted.json"
    chosen.write_text(text)
    page.set_input_files("#replay-file", str(chosen))
    _check_shown_as_text(page, console)
