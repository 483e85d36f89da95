"""The Mission Planner's REST API: ``/api/v1/missions`` and the call-a-drone endpoint.

Create (optionally start), preview (waypoints, time and battery per drone), the pre-flight
checklist (ground/planner/preflight.py, also run by every start), start, stop, pause, resume,
abort (every drone home), list, get, progress (per drone, with its time left and the mission's
timeline: ground/planner/progress_view.py), the mission log (JSON, downloadable) and what the drones
measured (GeoJSON or CSV). Refusals are 4xx with the reason; nothing changes."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from fastapi import APIRouter, Query, Request
from fastapi.responses import JSONResponse, Response
from pydantic import BaseModel, ConfigDict, Field

from dronefleet.errors import Unavailable
from dronefleet.ground.manager.context import Operator, Viewer, audited, ctx_of
from dronefleet.ground.manager.errors import answers
from dronefleet.ground.manager.schemas import MissionLog
from dronefleet.ground.planner import launch, measurements, preflight
from dronefleet.ground.planner.eta import etas_of
from dronefleet.ground.planner.mission_log import build_log
from dronefleet.ground.planner.mission_spec import MissionSpec
from dronefleet.ground.planner.preflight import PreflightReport
from dronefleet.ground.planner.progress_view import mission_progress
from dronefleet.ground.planner.schemas import (
    MissionDetail,
    MissionProgressView,
    MissionSummary,
    Preview,
    Readings,
)
from dronefleet.ground.planner.service import MissionPlanner

# Every route needs a token (401/403) and the planner (503); each adds what else it can answer.
router = APIRouter(prefix="/api/v1", tags=["missions"], responses=answers(401, 403, 422, 503))
#: A planning request: refused as not found (a drone), conflicting (busy, lost) or infeasible.
PLANNING = answers(404, 409, 504)


class CallRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")

    lat: float = Field(ge=-90, le=90)
    lon: float = Field(ge=-180, le=180)
    altitude_m: float = Field(default=10.0, gt=0, le=120)


def planner_of(request: Request) -> MissionPlanner:
    planner = getattr(request.app.state, "planner", None)
    if planner is None:
        raise Unavailable("the Mission Planner is not running")
    return planner


async def _guard(
    request: Request, who: Any, command: str, params: dict[str, Any], call: Any
) -> Any:
    """A planner call through the one audit wrapper (ground/manager/context.py); refusals go
    on up to the app's one error handler, which answers each with the status its class
    carries. The audit keeps {"ok": true}, not the plan."""
    return await audited(
        request, who, None, command, params, call,
        recorded=lambda _answer: {"ok": True}, silent="the Drone Identifier did not answer",
    )  # fmt: skip


@router.get("/missions", summary="All missions, newest first")
async def list_missions(request: Request, who: Viewer) -> list[MissionSummary]:
    records = sorted(planner_of(request).missions.values(), key=lambda r: -r.created_at)
    return [MissionSummary.model_validate(r.summary()) for r in records]


@router.post(
    "/missions/preview",
    summary="Waypoints, time and battery per drone; nothing is sent",
    responses=PLANNING,
)
async def preview(request: Request, spec: MissionSpec, who: Operator) -> Preview:
    planner = planner_of(request)
    answer = await _guard(request, who, "mission.preview", {}, launch.preview(planner, spec))
    return Preview.model_validate(answer)


@router.post(
    "/missions/preflight",
    summary="The pre-flight checklist: each drone's battery, GPS, link, sensors, fence and wind",
    responses=PLANNING,
)
async def preflight_checks(request: Request, spec: MissionSpec, who: Operator) -> PreflightReport:
    planner = planner_of(request)
    params = {"name": spec.name, "drones": spec.drones}
    call = preflight.preflight(planner, spec)
    return await _guard(request, who, "mission.preflight", params, call)


#: An operator's reason to fly although a pre-flight check failed (audited).
Override = Annotated[
    str | None,
    Query(
        min_length=3,
        max_length=500,
        description="fly although pre-flight checks failed; the reason, kept in the audit log",
    ),
]


def _gate(request: Request, who: Any, mission: str, override: str | None) -> launch.Gate:
    """The pre-flight checklist a start must pass; an override is audited with what it
    overrode."""

    async def overridden(failures: list[str]) -> None:
        params = {"mission": mission, "reason": override, "failed": failures}
        await ctx_of(request).gateway.audit(
            who, None, "mission.preflight_override", params, 200, {"ok": True}
        )

    return preflight.gate(planner_of(request), override, overridden)


@router.post(
    "/missions",
    status_code=201,
    summary="Create a mission (start it with ?start=true, after the pre-flight checklist)",
    responses=PLANNING,
)
async def create(
    request: Request,
    spec: MissionSpec,
    who: Operator,
    start: bool = Query(default=False),
    override: Override = None,
) -> MissionSummary:
    planner = planner_of(request)
    params = {"name": spec.name, "drones": spec.drones, "start": start, "override": override}
    gate = _gate(request, who, spec.name or "(new)", override)
    call = launch.create(planner, spec, start=start, gate=gate)
    record = await _guard(request, who, "mission.create", params, call)
    return MissionSummary.model_validate(record.summary())


@router.get(
    "/missions/{mission_id}", summary="A mission with its legs and progress", responses=answers(404)
)
async def get(request: Request, mission_id: str, who: Viewer) -> MissionDetail:
    record = planner_of(request).get(mission_id)
    return MissionDetail.model_validate(
        {**record.summary(), **record.model_dump(mode="json", exclude={"paths"})}
    )


@router.get(
    "/missions/{mission_id}/progress",
    summary="Each drone's share, current step and time left (vehicle s), and the timeline",
    responses=answers(404),
)
async def progress(request: Request, mission_id: str, who: Viewer) -> MissionProgressView:
    planner = planner_of(request)
    record = planner.get(mission_id)
    etas = await etas_of(planner).of(record, ctx_of(request).gateway.fleet)
    return MissionProgressView.model_validate(mission_progress(record, etas))


@router.post(
    "/missions/{mission_id}/start",
    summary="Start a planned mission (after the pre-flight checklist)",
    responses=PLANNING,
)
async def start(
    request: Request, mission_id: str, who: Operator, override: Override = None
) -> MissionSummary:
    planner = planner_of(request)
    call = launch.start(planner, mission_id, gate=_gate(request, who, mission_id, override))
    params = {"mission_id": mission_id, "override": override}
    record = await _guard(request, who, "mission.start", params, call)
    return MissionSummary.model_validate(record.summary())


@router.post(
    "/missions/{mission_id}/stop", summary="Stop a mission; its drones hold", responses=PLANNING
)
async def stop(request: Request, mission_id: str, who: Operator) -> MissionSummary:
    return await _stop(request, who, mission_id, home=False)


@router.post(
    "/missions/abort",
    summary="Abort every unfinished mission: all their drones stop and return home (RTL)",
)
async def abort_all(request: Request, who: Operator) -> list[MissionSummary]:
    planner = planner_of(request)
    call = planner.abort_all()
    records = await _guard(request, who, "mission.abort_all", {}, call)
    return [MissionSummary.model_validate(r.summary()) for r in records]


@router.post(
    "/missions/{mission_id}/abort",
    summary="Abort a mission: its drones stop and return home (RTL)",
    responses=PLANNING,
)
async def abort(request: Request, mission_id: str, who: Operator) -> MissionSummary:
    return await _stop(request, who, mission_id, home=True)


@router.post(
    "/missions/{mission_id}/pause",
    summary="Pause a mission: its drones hold and keep their steps for a resume",
    responses=PLANNING,
)
async def pause(request: Request, mission_id: str, who: Operator) -> MissionSummary:
    call = planner_of(request).pause_mission(mission_id)
    record = await _guard(request, who, "mission.pause", {"mission_id": mission_id}, call)
    return MissionSummary.model_validate(record.summary())


@router.post(
    "/missions/{mission_id}/resume",
    summary="Resume a paused mission (paused on request, or a drone taken over by someone else)",
    responses=PLANNING,
)
async def resume(request: Request, mission_id: str, who: Operator) -> MissionSummary:
    call = planner_of(request).resume_mission(mission_id)
    record = await _guard(request, who, "mission.resume", {"mission_id": mission_id}, call)
    return MissionSummary.model_validate(record.summary())


async def _stop(request: Request, who: Any, mission_id: str, *, home: bool) -> MissionSummary:
    call = planner_of(request).stop_mission(mission_id, home=home)
    command = "mission.abort" if home else "mission.stop"
    record = await _guard(request, who, command, {"mission_id": mission_id}, call)
    return MissionSummary.model_validate(record.summary())


@router.get(
    "/missions/{mission_id}/readings",
    summary="What the drones measured: one point per sensor reading, GeoJSON or CSV",
    responses={
        200: {
            "model": Readings,
            "content": {
                "application/geo+json": {"schema": {"$ref": "#/components/schemas/Readings"}},
                "text/csv": {"schema": {"type": "string"}},
            },
            "description": "a FeatureCollection of Points, or CSV with a header row",
        },
        **answers(404),
    },
)
async def mission_readings(
    request: Request,
    mission_id: str,
    who: Viewer,
    fmt: Literal["geojson", "csv"] = Query("geojson", alias="format"),
) -> Response:
    rows = measurements.readings(planner_of(request).get(mission_id))
    name = f"mission-{mission_id}-readings"
    if fmt == "csv":
        headers = {"Content-Disposition": f'attachment; filename="{name}.csv"'}
        return Response(measurements.csv_text(rows), media_type="text/csv", headers=headers)
    headers = {"Content-Disposition": f'attachment; filename="{name}.geojson"'}
    return JSONResponse(
        measurements.geojson(rows), media_type="application/geo+json", headers=headers
    )


@router.get(
    "/missions/{mission_id}/log",
    summary="The mission log (JSON) for the replay viewer",
    responses={
        200: {"model": MissionLog},
        **answers(404),
    },
)
async def mission_log(request: Request, mission_id: str, who: Viewer) -> JSONResponse:
    planner = planner_of(request)
    log = await planner.store.load_log(mission_id)
    if log is None:
        log = build_log(planner.get(mission_id))  # still running: the log so far (404 if none)
    headers = {"Content-Disposition": f'attachment; filename="mission-{mission_id}.json"'}
    return JSONResponse(log, headers=headers)


@router.post(
    "/call",
    status_code=201,
    summary="Call the nearest available drone to a position",
    responses=PLANNING,
)
async def call_drone(request: Request, body: CallRequest, who: Operator) -> MissionSummary:
    planner = planner_of(request)
    call = launch.call_drone(planner, body.lat, body.lon, altitude_m=body.altitude_m)
    record = await _guard(request, who, "call", body.model_dump(), call)
    return MissionSummary.model_validate(record.summary())
