"""The API docs work offline (issue 29, item 3): ``/docs`` was blank without the internet, as
FastAPI's page loads Swagger UI from a CDN. Now Swagger UI comes from npm and the ground serves it:
the page lists the API's operations with every request it makes going to the ground on 127.0.0.1,
and its Content-Security-Policy allows nothing else."""

from __future__ import annotations

from urllib.parse import urlsplit

import pytest

from .conftest import Console

pytestmark = pytest.mark.e2e


def test_docs_list_the_operations_with_no_request_leaving_the_ground(browser, demo):
    context = browser.new_context()
    try:
        page = context.new_page()
        console = Console(page)  # a CSP violation is a console error too
        requests: list[str] = []
        page.on("request", lambda r: requests.append(r.url))
        # Whatever would go elsewhere is recorded above and never sent.
        page.route(lambda url: urlsplit(url).hostname != "127.0.0.1", lambda route: route.abort())
        answer = page.goto(f"{demo.url}/docs")
        assert answer is not None and answer.ok
        page.wait_for_selector(".opblock", timeout=20_000)
        paths = page.locator(".opblock-summary-path").all_inner_texts()
        assert len(paths) > 40, paths
        assert any(p.replace("\u200b", "") == "/api/v1/missions" for p in paths), paths
        page.locator(".opblock").first.click()  # an operation opens (its parameters, answers)
        page.wait_for_selector(".opblock.is-open .responses-wrapper", timeout=5_000)
        elsewhere = [u for u in requests if urlsplit(u).scheme in ("http", "https", "ws", "wss")
                     and urlsplit(u).hostname != "127.0.0.1"]  # fmt: skip
        assert not elsewhere, elsewhere
        assert any("/web/vendor/swagger-ui/" in u for u in requests), requests
        console.assert_clean()

        policy = answer.headers["content-security-policy"]
        sources = {word for part in policy.split(";") for word in part.split()[1:]}
        assert sources <= {"'self'", "'none'", "'unsafe-inline'", "data:"}, policy
        assert "script-src 'self';" in policy  # no inline script either

        page.goto(f"{demo.url}/redoc")  # FastAPI's other docs page: the same docs
        assert urlsplit(page.url).path == "/docs"
    finally:
        context.close()
