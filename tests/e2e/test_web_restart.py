"""A restarted ground: the open page recovers by itself, and the printed tokens still work."""

from __future__ import annotations

import re
import urllib.error
import urllib.request

import pytest

from .conftest import free_port, get, start_demo

pytestmark = pytest.mark.e2e

#: What Chromium logs while the server is down: failed fetches and WebSocket connections.
CONNECTION_LOST = re.compile(r"net::ERR_CONNECTION_REFUSED|WebSocket connection to .* failed")


def test_the_fleet_page_recovers_by_itself_when_the_server_restarts(open_page, tmp_path):
    port = free_port()
    first = start_demo(tmp_path, "--drones", "1", port=port, log="first.log")
    token = first.operator  # its hash is kept in the state dir: the restarted demo accepts it
    try:
        assert first.url == f"http://127.0.0.1:{port}"
        page, console = open_page("fleet", server=first)
        page.wait_for_selector("#fleet-table tr[data-drone='QUAD_1'][data-status='online']")
        page.evaluate("window.notReloaded = true")
        console.assert_clean()
    finally:
        first.stop()
    page.wait_for_function(
        "() => document.getElementById('link-state').dataset.state !== 'live'", timeout=20_000
    )
    assert page.get_attribute("#link-state", "data-state") == "reconnecting"
    assert page.locator("#fleet-table tr[data-drone='QUAD_2']").count() == 0

    # Same port and state dir; a second drone only this server has.
    second = start_demo(tmp_path, "--drones", "2", port=port, log="second.log")
    try:
        assert second.url == first.url and second.operator is None  # no token printed again
        assert get(second, "/web/me", token=token)["role"] == "operator"
        page.wait_for_selector("#link-state[data-state='live']", timeout=45_000)
        page.wait_for_selector(
            "#fleet-table tr[data-drone='QUAD_2'][data-status='online']", timeout=30_000
        )
        page.wait_for_selector("#fleet-table tr[data-drone='QUAD_1'][data-status='online']")
        assert page.evaluate("window.notReloaded === true"), "the page was reloaded"
        assert not page.locator("#login").is_visible(), "the page asked for a token again"
        down = [e for e in console.errors if not CONNECTION_LOST.search(e)]
        assert not down, f"errors besides the lost connection: {down}"
        console.errors.clear()
        page.wait_for_function(  # the stream's heartbeats update the table again
            """() => [...document.querySelectorAll('#fleet-table tbody tr td:last-child')]
                      .every((td) => /^[0-2] s ago$/.test(td.textContent))""",
            timeout=20_000,
        )
        console.assert_clean()
    finally:
        second.stop()


def test_the_tokens_a_demo_printed_still_work_after_it_restarts(tmp_path):
    first = start_demo(tmp_path, "--drones", "1", log="first.log")
    first.stop()
    second = start_demo(tmp_path, "--drones", "1", log="second.log")
    try:
        for role, token in (("operator", first.operator), ("viewer", first.viewer)):
            try:
                me = get(second, "/web/me", token=token)
            except urllib.error.HTTPError as exc:
                raise AssertionError(f"the first {role} token is refused: {exc.code}") from exc
            assert me["role"] == role
    finally:
        second.stop()
