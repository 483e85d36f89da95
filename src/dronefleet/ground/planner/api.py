"""The Mission Planner's REST API: ``/api/v1/missions`` and the call-a-drone endpoint.

Create (optionally start), preview (waypoints, time and battery per drone), start, stop, list,
get, and the mission log (JSON, downloadable). Refusals are 4xx with the reason; nothing changes.
"""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Query, Request
from fastapi.responses import JSONResponse
from pydantic import BaseModel, ConfigDict, Field

from dronefleet.ground.manager.context import Operator, Viewer, ctx_of
from dronefleet.ground.manager.errors import ApiError
from dronefleet.ground.planner import launch
from dronefleet.ground.planner.launch import MissionSpec
from dronefleet.ground.planner.service import MissionPlanner, PlannerError
from dronefleet.messaging.rpc import RequestTimeout

router = APIRouter(prefix="/api/v1", tags=["missions"])


class CallRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")

    lat: float = Field(ge=-90, le=90)
    lon: float = Field(ge=-180, le=180)
    altitude_m: float = Field(default=10.0, gt=0, le=120)


def planner_of(request: Request) -> MissionPlanner:
    planner = getattr(request.app.state, "planner", None)
    if planner is None:
        raise ApiError(503, "the Mission Planner is not running")
    return planner


async def _guard(
    request: Request, who: Any, command: str, params: dict[str, Any], call: Any
) -> Any:
    """Run a planner call: planner refusals become 4xx, all of it goes to the audit log."""
    gateway = ctx_of(request).gateway
    try:
        answer = await call
    except PlannerError as exc:
        error = ApiError(exc.status, str(exc))
        await gateway.audit(who, None, command, params, error.status, error.body())
        raise error from exc
    except RequestTimeout as exc:
        error = ApiError(504, f"the Drone Identifier did not answer: {exc}")
        await gateway.audit(who, None, command, params, 504, error.body())
        raise error from exc
    await gateway.audit(who, None, command, params, 200, {"ok": True})
    return answer


@router.get("/missions", summary="All missions, newest first")
async def list_missions(request: Request, who: Viewer) -> list[dict[str, Any]]:
    records = sorted(planner_of(request).missions.values(), key=lambda r: -r.created_at)
    return [r.summary() for r in records]


@router.post("/missions/preview", summary="Waypoints, time and battery per drone; nothing is sent")
async def preview(request: Request, spec: MissionSpec, who: Operator) -> dict[str, Any]:
    planner = planner_of(request)
    return await _guard(request, who, "mission.preview", {}, launch.preview(planner, spec))


@router.post("/missions", status_code=201, summary="Create a mission (start it with ?start=true)")
async def create(
    request: Request, spec: MissionSpec, who: Operator, start: bool = Query(default=False)
) -> dict[str, Any]:
    planner = planner_of(request)
    params = {"name": spec.name, "drones": spec.drones, "start": start}
    record = await _guard(
        request, who, "mission.create", params, launch.create(planner, spec, start=start)
    )
    return record.summary()


@router.get("/missions/{mission_id}", summary="A mission with its legs and progress")
async def get(request: Request, mission_id: str, who: Viewer) -> dict[str, Any]:
    try:
        record = planner_of(request).get(mission_id)
    except PlannerError as exc:
        raise ApiError(exc.status, str(exc)) from exc
    return {**record.summary(), **record.model_dump(mode="json", exclude={"paths"})}


@router.post("/missions/{mission_id}/start", summary="Start a planned mission")
async def start(request: Request, mission_id: str, who: Operator) -> dict[str, Any]:
    planner = planner_of(request)
    call = launch.start(planner, mission_id)
    record = await _guard(request, who, "mission.start", {"mission_id": mission_id}, call)
    return record.summary()


@router.post("/missions/{mission_id}/stop", summary="Stop a mission; its drones hold")
async def stop(request: Request, mission_id: str, who: Operator) -> dict[str, Any]:
    planner = planner_of(request)
    call = planner.stop_mission(mission_id)
    record = await _guard(request, who, "mission.stop", {"mission_id": mission_id}, call)
    return record.summary()


@router.get("/missions/{mission_id}/log", summary="The mission log (JSON) for the replay viewer")
async def mission_log(request: Request, mission_id: str, who: Viewer) -> JSONResponse:
    planner = planner_of(request)
    log = await planner.store.load_log(mission_id)
    if log is None:
        try:
            record = planner.get(mission_id)
        except PlannerError as exc:
            raise ApiError(404, str(exc)) from exc
        from dronefleet.ground.planner.mission_log import build_log

        log = build_log(record)  # still running: the log so far
    headers = {"Content-Disposition": f'attachment; filename="mission-{mission_id}.json"'}
    return JSONResponse(log, headers=headers)


@router.post("/call", status_code=201, summary="Call the nearest available drone to a position")
async def call_drone(request: Request, body: CallRequest, who: Operator) -> dict[str, Any]:
    planner = planner_of(request)
    call = launch.call_drone(planner, body.lat, body.lon, altitude_m=body.altitude_m)
    record = await _guard(request, who, "call", body.model_dump(), call)
    return record.summary()
