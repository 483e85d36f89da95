"""Mission files over REST (issue 14): import a .plan or KML; export a mission or preview as .plan.

``POST /api/v1/missions/import`` takes the file as the request body (what a browser's file input
reads; no multipart form) and answers what ``POST /api/v1/missions`` takes, with warnings; a file
that cannot be imported is a 422 with the reason. The body limit is the Drone Manager's own
(ground/manager/hardening.py, 4 MB). ``GET /api/v1/missions/{id}/plan`` and ``POST
/api/v1/missions/preview/plan`` answer a .plan as a download. Parsing and planning run in the
planning worker (ground/planner/worker.py): a file is untrusted input and may be large.
"""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Query, Request
from fastapi.responses import JSONResponse

from dronefleet.geo.types import LLA
from dronefleet.ground.manager.context import Operator, Viewer
from dronefleet.ground.manager.errors import answers
from dronefleet.ground.planner.api import planner_of
from dronefleet.ground.planner.files.imported import FileKind, ImportedMission, MissionFileError
from dronefleet.ground.planner.files.kml import read_kml
from dronefleet.ground.planner.files.plan import read_plan
from dronefleet.ground.planner.files.plan_export import PlanDocument, write_plan
from dronefleet.ground.planner.mission_spec import MissionSpec, check_altitudes, work_of
from dronefleet.ground.planner.service import MissionPlanner

router = APIRouter(prefix="/api/v1", tags=["missions"], responses=answers(401, 403, 422, 503))

#: The request body of an import, as the OpenAPI document publishes it.
_IMPORT_BODY: dict[str, Any] = {
    "requestBody": {
        "required": True,
        "description": "the file itself: a QGroundControl .plan (JSON) or a KML (XML)",
        "content": {
            "application/json": {"schema": {"type": "object"}},
            "application/vnd.google-earth.kml+xml": {"schema": {"type": "string"}},
        },
    }
}
_PLAN_FILE: dict[int | str, dict[str, Any]] = {
    200: {"model": PlanDocument, "description": "a QGroundControl .plan (JSON), as a download"}
}


def sniff(data: bytes) -> FileKind:
    """Which kind of file ``data`` is, from its first bytes."""
    head = data.removeprefix(b"\xef\xbb\xbf").lstrip()[:1]
    if head == b"{":
        return FileKind.PLAN
    if head == b"<" or data[:2] == b"PK":
        return FileKind.KML
    raise MissionFileError("not a QGroundControl .plan (JSON) nor a KML (XML) file")


def read_file(kind: FileKind, data: bytes, name: str) -> ImportedMission:
    """Parse ``data`` (runs in the planning worker)."""
    return read_plan(data, name) if kind is FileKind.PLAN else read_kml(data, name)


def preview_plan(spec: MissionSpec, max_altitude_m: float, home: LLA | None) -> dict[str, Any]:
    """The .plan of what ``spec`` would fly (runs in the planning worker: an area is planned)."""
    work, _plan = work_of(spec)
    check_altitudes(work, max_altitude_m)
    options = spec.options
    return write_plan(
        work, home=home, rally_points=[p.model_dump() for p in options.rally_points],
        geofence=options.geofence.model_dump() if options.geofence else None,
    )  # fmt: skip


async def _home(planner: MissionPlanner, drones: list[str]) -> LLA | None:
    """The planned home of a file: the first drone's home, when the fleet knows it."""
    if not drones:
        return None
    try:
        fleet = {d.drone_id: d for d in await planner.fleet.drones()}
    except Exception:  # no fleet answer: the file's home is its first waypoint instead
        return None
    drone = fleet.get(drones[0])
    return drone.home if drone is not None else None


def _download(document: dict[str, Any], name: str) -> JSONResponse:
    headers = {"Content-Disposition": f'attachment; filename="{name}.plan"'}
    return JSONResponse(document, headers=headers)


@router.post(
    "/missions/import",
    summary="Read a QGroundControl .plan or a KML polygon into a mission request",
    openapi_extra=_IMPORT_BODY,
)
async def import_file(
    request: Request,
    who: Operator,
    kind: Annotated[
        FileKind | None, Query(alias="format", description="default: from the first bytes")
    ] = None,
    name: Annotated[
        str, Query(max_length=200, description="the mission's name if the file has none")
    ] = "",
) -> ImportedMission:
    data = await request.body()
    if not data:
        raise MissionFileError("the request body is empty: send the file itself")
    planner = planner_of(request)
    return await planner.worker.run(read_file, kind or sniff(data), data, name)


@router.get(
    "/missions/{mission_id}/plan",
    summary="A mission as a QGroundControl .plan file",
    responses={**_PLAN_FILE, **answers(404)},
    response_class=JSONResponse,
)
async def export_mission(request: Request, mission_id: str, who: Viewer) -> JSONResponse:
    planner = planner_of(request)
    record = planner.get(mission_id)
    options = record.options
    document = write_plan(
        record.work, home=await _home(planner, record.drones),
        geofence=options.geofence.model_dump() if options.geofence else None,
        rally_points=[p.model_dump() for p in options.rally_points],
    )  # fmt: skip
    return _download(document, f"mission-{mission_id}")


@router.post(
    "/missions/preview/plan",
    summary="What a mission request would fly, as a QGroundControl .plan file; nothing is sent",
    responses=_PLAN_FILE,
    response_class=JSONResponse,
)
async def export_preview(request: Request, spec: MissionSpec, who: Operator) -> JSONResponse:
    planner = planner_of(request)
    home = await _home(planner, spec.drones)
    document = await planner.worker.run(preview_plan, spec, planner.max_altitude_m, home)
    return _download(document, "preview")
