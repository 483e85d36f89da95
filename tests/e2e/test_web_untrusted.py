"""Everything from the broker is untrusted input to the web page (issue 12, must-show 3).

A drone announcing itself with an HTML payload for an id is refused by the ground (ids follow the
topic pattern), so it never reaches a page; the map builds its labels from text nodes, so such an
id would show as text; and the page's Content-Security-Policy refuses inline script.
"""

from __future__ import annotations

import json
import time
from urllib.parse import urlsplit

import paho.mqtt.publish as publish
import pytest

from .conftest import get

pytestmark = pytest.mark.e2e

PAYLOAD = '<img src=x onerror="window.__xss=1">'


def _announce(demo, drone_id: str) -> None:
    where = urlsplit(demo.broker)
    heartbeat = {
        "drone_id": drone_id,
        "vehicle_time_s": 1.0,
        "interval_s": 1.0,
        "position": {"lat": 40.63, "lon": -8.659, "alt_m": 10.0},
        "battery": {"remaining_pct": 90.0, "voltage_v": 12.0},
        "state": "flying",
        "mode": "GUIDED",
    }
    publish.single(
        f"{drone_id}/heartbeats/out",
        json.dumps(heartbeat),
        hostname=where.hostname,
        port=where.port,
    )


def test_a_drone_whose_id_is_html_never_reaches_the_page_and_no_script_runs(open_page, demo):
    page, _console = open_page("fleet")
    page.wait_for_selector("#fleet-table tbody tr")
    for _ in range(3):
        _announce(demo, PAYLOAD)
        time.sleep(0.5)
    time.sleep(1.5)
    assert all(d["drone_id"] != PAYLOAD for d in get(demo, "/drones"))
    assert page.evaluate("window.__xss") is None
    assert PAYLOAD not in page.content()


def test_the_map_shows_an_untrusted_label_as_text(open_page):
    page, console = open_page("fleet")
    label = page.evaluate(
        """async (payload) => {
          const { droneIcon } = await import('/web/js/map.js');
          const box = document.createElement('div');
          box.style.width = box.style.height = '200px';
          document.body.appendChild(box);
          const map = L.map(box).setView([40.63, -8.659], 16);
          L.marker([40.63, -8.659], { icon: droneIcon({ drone_id: payload, status: 'online' }) })
            .addTo(map);
          await new Promise((r) => setTimeout(r, 200));
          return box.querySelector('.drone-label').textContent;
        }""",
        PAYLOAD,
    )
    assert label == PAYLOAD
    assert page.evaluate("window.__xss") is None
    console.assert_clean()


def test_the_content_security_policy_refuses_inline_script(open_page):
    page, _console = open_page("fleet")
    page.evaluate(
        """() => {
          const s = document.createElement('script');
          s.textContent = 'window.__inline = 1';
          document.body.appendChild(s);
        }"""
    )
    assert page.evaluate("window.__inline") is None
