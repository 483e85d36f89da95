"""The API docs at ``/docs``, served by the ground itself, so they work offline (issue 29).

FastAPI's own ``/docs`` and ``/redoc`` pages load Swagger UI and ReDoc from a CDN (and fonts from
Google): on a field laptop without the internet, ``/docs`` was blank. Here Swagger UI comes from
npm (``swagger-ui-dist``, pinned in package-lock.json, copied into ``web/vendor/swagger-ui/`` by
``scripts/web-deps.sh``, as Leaflet is) and is started by our own script (``web/js/docs.js``): no
inline script, nothing from elsewhere, so the page's Content-Security-Policy
(``hardening.DOCS_POLICY``) allows this server only. ``/redoc`` sends to ``/docs``. The app is
made with ``docs_url=None, redoc_url=None`` (manager/app.py) and includes :data:`router`.
"""

from __future__ import annotations

from html import escape

from fastapi import APIRouter, Request
from fastapi.responses import HTMLResponse, RedirectResponse

#: Where scripts/web-deps.sh puts Swagger UI (served by web.py's static files).
ASSETS = "/web/vendor/swagger-ui"

PAGE = """<!doctype html>
<html lang="en">
<head>
  <meta charset="utf-8">
  <meta name="viewport" content="width=device-width, initial-scale=1">
  <title>{title} - API docs</title>
  <link rel="icon" href="{assets}/favicon-32x32.png">
  <link rel="stylesheet" href="{assets}/swagger-ui.css">
</head>
<body>
  <div id="swagger-ui" data-openapi="{openapi}">
    <p id="docs-missing" hidden>The API docs' Swagger UI is missing from this installation: run
    <code>bash scripts/web-deps.sh</code> in the checkout. The API's description is at
    <a href="{openapi}">{openapi}</a>.</p>
  </div>
  <script src="{assets}/swagger-ui-bundle.js"></script>
  <script src="/web/js/docs.js"></script>
</body>
</html>
"""

router = APIRouter(include_in_schema=False)


@router.get("/docs")
async def docs(request: Request) -> HTMLResponse:
    """Swagger UI on this server's OpenAPI description."""
    app = request.app
    page = PAGE.format(
        title=escape(app.title),
        assets=ASSETS,
        openapi=escape(app.openapi_url or "/openapi.json"),
    )
    return HTMLResponse(page, headers={"Cache-Control": "no-cache"})


@router.get("/redoc")
async def redoc() -> RedirectResponse:
    """FastAPI's other docs page (ReDoc, from a CDN) is not served: the same docs are at /docs."""
    return RedirectResponse("/docs")
