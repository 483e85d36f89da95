"""The web apps (seed 4.2.1, 4.2.3, 4.2.4, 5.1): ``/`` and the static files under ``/web/``.

The pages are plain HTML/CSS/JS from ``dronefleet/web`` in the installed package; the third-party
libraries (Leaflet, Leaflet-Geoman, Chart.js) are copied from npm into ``web/vendor/`` by
``scripts/web-deps.sh``.
``/api/v1/web/config`` tells the pages which map tiles to use: a tile server's URL template, the
ground's own MBTiles tiles (``local_tiles``: fetched with credentials, metadata at
``/api/v1/tiles``), or none (an offline grid).
"""

import mimetypes
from pathlib import Path
from typing import Any

from fastapi import APIRouter, FastAPI, Request
from fastapi.responses import FileResponse, RedirectResponse
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.responses import Response
from starlette.staticfiles import StaticFiles
from starlette.types import Scope

from dronefleet.ground.manager.context import Viewer
from dronefleet.ground.manager.errors import ApiError, answers
from dronefleet.ground.manager.maps import TILE_TEMPLATE
from dronefleet.ground.manager.schemas import Me, WebConfig

WEB_ROOT = Path(__file__).resolve().parents[2] / "web"
# Module scripts are refused by browsers unless served as JavaScript; the system's MIME table
# may not know .mjs, and Python 3.11's says application/javascript for .js (both work).
mimetypes.add_type("text/javascript", ".mjs")
mimetypes.add_type("text/css", ".css")


class WebFiles(StaticFiles):
    """Starlette's static files (path checks, NUL bytes, ETag, HEAD, ranges: a kept library
    rather than our own file server), revalidated on every load so a new version shows at once,
    and a 404 that says how to get the vendored libraries."""

    def file_response(self, *args: Any, **kwargs: Any) -> Response:
        response = super().file_response(*args, **kwargs)
        response.headers["Cache-Control"] = "no-cache"
        return response

    async def get_response(self, path: str, scope: Scope) -> Response:
        try:
            return await super().get_response(path, scope)
        except StarletteHTTPException as exc:
            if exc.status_code != 404:
                raise
            hint = " (run `bash scripts/web-deps.sh`)" if path.startswith("vendor/") else ""
            raise ApiError(404, f"no web file {path!r}{hint}") from None


def mount(app: FastAPI) -> None:
    """Serve ``dronefleet/web`` under ``/web/`` (not in the OpenAPI: files, not operations)."""
    app.mount("/web", WebFiles(directory=WEB_ROOT, check_dir=False), name="web")


router = APIRouter(tags=["web"])


@router.get("/", include_in_schema=False)
async def index() -> FileResponse:
    return FileResponse(
        WEB_ROOT / "index.html",
        media_type="text/html; charset=utf-8",
        headers={"Cache-Control": "no-cache"},
    )


@router.get("/call", include_in_schema=False)
async def call_page() -> RedirectResponse:
    """The phone page's short address: the seed's panic button."""
    return RedirectResponse("/#/call")


@router.get(
    "/api/v1/web/config",
    summary="What the web apps need: the map tile URL (or none)",
    response_model=WebConfig,
)
async def web_config(request: Request) -> dict[str, Any]:
    if getattr(request.app.state, "mbtiles", None) is not None:
        return {"tiles": TILE_TEMPLATE, "local_tiles": True}
    return {"tiles": getattr(request.app.state, "web_tiles", None), "local_tiles": False}


@router.get(
    "/api/v1/web/me",
    summary="Who the token belongs to: name and role (viewer/operator/admin)",
    responses=answers(401),
    response_model=Me,
)
async def web_me(who: Viewer) -> dict[str, Any]:
    return {"name": who.name, "role": who.role.label, "can_command": who.role >= 2}
