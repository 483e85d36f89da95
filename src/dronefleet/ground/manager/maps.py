"""Map tiles from the ground itself: ``/api/v1/tiles`` (an MBTiles file's metadata) and
``/api/v1/tiles/{z}/{x}/{y}`` (its tiles), for the web maps without a network (issue 14).

Both need a viewer's credentials, exactly as every other read route (the same dependency, so a
session the Drone Manager accepts elsewhere is accepted here): imagery of the operating area is
the operator's, not the network's. The web maps fetch each tile with the page's credentials
(web/js/tiles.js). A tile the file does not hold is a 404, which the map leaves blank over the
grid drawn underneath.
"""

from __future__ import annotations

from fastapi import APIRouter, Path, Request
from starlette.responses import Response

from dronefleet.errors import NotFound
from dronefleet.ground.manager.context import Viewer
from dronefleet.ground.manager.errors import answers
from dronefleet.ground.manager.mbtiles import MAX_ZOOM, MBTiles, TileSet
from dronefleet.ground.manager.schemas import binary

router = APIRouter(prefix="/api/v1/tiles", tags=["web"], responses=answers(401, 403, 404, 422))

#: The route the web maps are given as their tile URL template.
TILE_TEMPLATE = "/api/v1/tiles/{z}/{x}/{y}"
#: Private: the tiles need credentials, so no shared cache may keep them; a browser may, an hour.
CACHE = "private, max-age=3600"


def mbtiles_of(request: Request) -> MBTiles:
    found = getattr(request.app.state, "mbtiles", None)
    if found is None:
        raise NotFound("this ground serves no map tiles: start it with --tiles FILE.mbtiles")
    return found


@router.get("", summary="The map tiles this ground serves: name, bounds, centre, zooms")
async def tileset(request: Request, who: Viewer) -> TileSet:
    return mbtiles_of(request).tileset


@router.get(
    "/{z}/{x}/{y}",
    summary="One map tile (XYZ numbering, as web maps ask), from the ground's MBTiles file",
    responses=binary("image/png", "image/jpeg", "image/webp"),
    response_class=Response,
)
async def tile(
    request: Request,
    who: Viewer,
    z: int = Path(ge=0, le=MAX_ZOOM),
    x: int = Path(ge=0),
    y: int = Path(ge=0),
) -> Response:
    tiles = mbtiles_of(request)
    data = await tiles.tile(z, x, y)
    if data is None:
        raise NotFound(f"no tile {z}/{x}/{y} in {tiles.path.name}")
    return Response(data, media_type=tiles.media_type, headers={"Cache-Control": CACHE})
