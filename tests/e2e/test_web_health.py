"""The ground's health on every page (issue 26, item 7): a banner while the ground is degraded.

A ``dronefleet ground`` on a Mosquitto of the test's own: the broker is stopped under an open
page, whose banner then says the broker is lost; the broker is started again on its port, the
ground's services reconnect by themselves and the banner goes.
"""

from __future__ import annotations

import re
import secrets

import pytest

from support.brokers import Mosquitto
from support.ground_procs import ground_cmd, process, wait_http

from .conftest import Console, free_port

pytestmark = pytest.mark.e2e

#: What Chromium logs while the broker is away: the health answers 503 (that is the point),
#: and what the page asks the Drone Identifier over the broker meanwhile is a 504.
DEGRADED = re.compile(r"status of 50[34]")


def test_a_banner_shows_while_the_broker_is_lost_and_goes_when_it_is_back(browser, tmp_path):
    broker = Mosquitto(tmp_path)
    url = broker.start()
    token = secrets.token_urlsafe(16)
    port = free_port()
    ground = ground_cmd(f"mqtt://{url.host}:{url.port}", tmp_path, port, token)
    try:
        with process(ground, tmp_path / "ground.log"):
            http = f"http://127.0.0.1:{port}"
            wait_http(http, log=tmp_path / "ground.log")
            context = browser.new_context(viewport={"width": 1280, "height": 860})
            try:
                page = context.new_page()
                console = Console(page)
                page.goto(f"{http}/?token={token}#/fleet")
                page.wait_for_selector("#page[data-mounted='fleet']", timeout=15_000)
                page.wait_for_timeout(1_000)  # a first poll has come back ok
                assert page.locator("#health").is_hidden()

                broker.stop()
                banner = page.locator("#health")
                banner.wait_for(state="visible", timeout=20_000)
                text = banner.inner_text()
                assert text.startswith("Ground degraded: broker: not connected to the broker"), text
                assert banner.get_attribute("role") == "alert"
                # On any page: the Control page shows it too.
                page.goto(f"{http}/#/control")
                page.wait_for_selector("#page[data-mounted='control']", timeout=15_000)
                banner.wait_for(state="visible", timeout=20_000)

                broker.start()  # again, on its port
                banner.wait_for(state="hidden", timeout=45_000)
                others = [e for e in console.errors if not DEGRADED.search(e)]
                assert not others, f"errors besides the degraded health: {others}"
            finally:
                context.close()
    finally:
        broker.stop()
