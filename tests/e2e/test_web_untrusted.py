"""Everything from the broker is untrusted input to the web page (issue 12, must-show 3).

A stranger cannot connect to the demo's broker at all (so cannot command a drone, nor announce a
drone whose id is an HTML payload — which the ground would refuse anyway, ids follow the topic
pattern); the map builds its labels from text nodes, so such an id would show as text; and the
page's Content-Security-Policy refuses inline script.
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


def test_the_anonymous_takeoff_attack_is_refused_and_the_drone_stays_down(demo):
    """Issue 12, must-show 2: a stranger on the demo's broker publishes a takeoff."""
    where = urlsplit(demo.broker)
    assert where.password is None and where.username is None  # nothing printed lets one in
    idle = [d["drone_id"] for d in get(demo, "/drones") if d["state"] == "disarmed"]
    assert idle, "no drone on the ground to attack"
    target = idle[-1]
    with pytest.raises(Exception, match=r"(?i)not authori[sz]ed|refused|bad user"):
        publish.single(
            f"{target}/control/in",
            json.dumps({"request_id": "evil", "command": "arm"}),
            hostname=where.hostname,
            port=where.port,
        )
    time.sleep(2.0)
    assert next(d for d in get(demo, "/drones") if d["drone_id"] == target)["state"] == "disarmed"


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


def test_the_page_keeps_no_token_an_injected_script_could_read(open_page, demo):
    """Issue 12: the sign-in link's token is traded for an HttpOnly session and forgotten; what
    page script can reach (storage, document.cookie, the address bar) holds no credential."""
    page, console = open_page("fleet")
    assert "token" not in page.url
    reachable = page.evaluate(
        """() => JSON.stringify([document.cookie, location.href, history.length,
             Object.entries(localStorage), Object.entries(sessionStorage)])"""
    )
    assert demo.operator not in reachable
    assert "dronefleet_session" not in reachable  # HttpOnly: not in document.cookie
    # The session works for the page's own calls, without a token anywhere in them.
    me = page.evaluate("async () => (await import('/web/js/api.js')).api('/web/me')")
    assert me["role"] == "operator"
    # Signing out ends it: the page asks for a token again and its calls are refused.
    page.click("#logout")
    page.wait_for_selector("#login[open]", timeout=15_000)
    status = page.evaluate(
        "async () => (await fetch('/api/v1/web/me', {credentials: 'same-origin'})).status"
    )
    assert status == 401
    console.errors[:] = [e for e in console.errors if "401" not in e]
    console.assert_clean()
