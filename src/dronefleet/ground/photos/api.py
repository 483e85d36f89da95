"""The pictures' REST routes: ``/api/v1/missions/{id}/photos`` and what hangs under it (issue 14).

The list (where, when, which step, whether the ground has it), each picture as the drone took
it (``image/jpeg``, its GPS EXIF intact), its thumbnail, and ``photos.zip``: a folder of
geotagged JPEGs, as OpenDroneMap and other photogrammetry tools take them. A viewer may read
them all.
"""

from __future__ import annotations

from fastapi import APIRouter, Path, Request
from fastapi.responses import FileResponse

from dronefleet.errors import NotFound, Unavailable
from dronefleet.ground.manager.context import Viewer
from dronefleet.ground.manager.errors import answers
from dronefleet.ground.manager.schemas import binary
from dronefleet.ground.photos.store import PhotoEntry, PhotoStore

router = APIRouter(
    prefix="/api/v1/missions", tags=["missions"], responses=answers(401, 403, 404, 422, 503)
)
JPEG = binary("image/jpeg")
#: A picture never changes once kept, but it is the operator's: a browser may keep it, no proxy.
CACHE = "private, max-age=86400"


def store_of(request: Request, mission_id: str) -> PhotoStore:
    """The ground's picture store, once ``mission_id`` is known to the planner (404 if not)."""
    planner = getattr(request.app.state, "planner", None)
    store = getattr(request.app.state, "photos", None)
    if planner is None or store is None:
        raise Unavailable("the ground keeps no pictures: the Mission Planner is not running")
    planner.get(mission_id)
    return store


async def _stored(request: Request, mission_id: str, n: int) -> tuple[PhotoStore, PhotoEntry]:
    store = store_of(request, mission_id)
    entry = await store.entry(mission_id, n)
    if not entry.stored:
        why = f": {entry.error}" if entry.error else " (it is being fetched from the drone)"
        raise NotFound(f"picture {n} of mission {mission_id} is not on the ground yet{why}")
    return store, entry


@router.get(
    "/{mission_id}/photos",
    summary="The mission's pictures: number, drone, step, position, time; whether each is here",
)
async def photos(request: Request, mission_id: str, who: Viewer) -> list[PhotoEntry]:
    return await store_of(request, mission_id).entries(mission_id)


@router.get(
    "/{mission_id}/photos.zip",
    summary="Every picture the ground has, as geotagged JPEGs in one zip (for photogrammetry)",
    responses=binary("application/zip"),
    response_class=FileResponse,
)
async def photos_zip(request: Request, mission_id: str, who: Viewer) -> FileResponse:
    path = await store_of(request, mission_id).zip_path(mission_id)
    return FileResponse(
        path, media_type="application/zip", filename=f"mission-{mission_id}-photos.zip"
    )


@router.get(
    "/{mission_id}/photos/{n}",
    summary="One picture as the drone took it (JPEG with its GPS EXIF)",
    responses=JPEG,
    response_class=FileResponse,
)
async def photo(
    request: Request, mission_id: str, who: Viewer, n: int = Path(ge=1)
) -> FileResponse:
    store, entry = await _stored(request, mission_id, n)
    return FileResponse(
        store.picture_path(mission_id, entry),
        media_type="image/jpeg",
        filename=entry.name,
        content_disposition_type="inline",
        headers={"Cache-Control": CACHE},
    )


@router.get(
    "/{mission_id}/photos/{n}/thumb",
    summary="A picture's thumbnail (JPEG, 256 px at most)",
    responses=JPEG,
    response_class=FileResponse,
)
async def thumb(
    request: Request, mission_id: str, who: Viewer, n: int = Path(ge=1)
) -> FileResponse:
    store, entry = await _stored(request, mission_id, n)
    return FileResponse(
        store.thumb_path(mission_id, entry),
        media_type="image/jpeg",
        headers={"Cache-Control": CACHE},
    )
