"""The web apps (seed 4.2.1, 4.2.3, 4.2.4, 5.1): ``/`` and the static files under ``/web/``.

The pages are plain HTML/CSS/JS from ``dronefleet/web`` in the installed package; the third-party
libraries (Leaflet, Chart.js) are copied from npm into ``web/vendor/`` by ``scripts/web-deps.sh``.
``/api/v1/web/config`` tells the pages which map tiles to use (none: an offline grid).
"""

from pathlib import Path
from typing import Any

from fastapi import APIRouter, Request
from fastapi.responses import FileResponse, RedirectResponse

from dronefleet.ground.manager.context import Viewer
from dronefleet.ground.manager.errors import ApiError, answers
from dronefleet.ground.manager.schemas import Me, WebConfig

WEB_ROOT = Path(__file__).resolve().parents[2] / "web"
_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".mjs": "text/javascript; charset=utf-8",
    ".css": "text/css; charset=utf-8",
    ".svg": "image/svg+xml",
    ".png": "image/png",
    ".json": "application/json",
}

router = APIRouter(tags=["web"])


def _file(relative: str) -> FileResponse:
    # A NUL cannot be in a file name; the OS calls would refuse it with a ValueError (a 500).
    path = WEB_ROOT if "\x00" in relative else (WEB_ROOT / relative).resolve()
    if not path.is_relative_to(WEB_ROOT) or not path.is_file():
        hint = " (run `bash scripts/web-deps.sh`)" if relative.startswith("vendor/") else ""
        raise ApiError(404, f"no web file {relative!r}{hint}")
    media = _TYPES.get(path.suffix, "application/octet-stream")
    return FileResponse(path, media_type=media, headers={"Cache-Control": "no-cache"})


@router.get("/", include_in_schema=False)
async def index() -> FileResponse:
    return _file("index.html")


@router.get("/call", include_in_schema=False)
async def call_page() -> RedirectResponse:
    """The phone page's short address: the seed's panic button."""
    return RedirectResponse("/#/call")


@router.get("/web/{relative:path}", include_in_schema=False)
async def static(relative: str) -> FileResponse:
    return _file(relative)


@router.get(
    "/api/v1/web/config",
    summary="What the web apps need: the map tile URL (or none)",
    response_model=WebConfig,
)
async def web_config(request: Request) -> dict[str, Any]:
    return {"tiles": getattr(request.app.state, "web_tiles", None)}


@router.get(
    "/api/v1/web/me",
    summary="Who the token belongs to: name and role (viewer/operator/admin)",
    responses=answers(401),
    response_model=Me,
)
async def web_me(who: Viewer) -> dict[str, Any]:
    return {"name": who.name, "role": who.role.label, "can_command": who.role >= 2}
