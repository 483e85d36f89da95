"""Per-drone mission routes: ``POST /api/v1/drones/{id}/pause|resume|abort`` (issue 14).

The per-drone panel's buttons (Pause, Resume, Abort; RTL is the drone command
``/commands/rtl``). Each acts on the drone's leg of the mission it flies
(ground/planner/drone_ops.py), needs the operator role and is audited like every command; a
drone that flies no mission is a 409 with the reason.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import Annotated

from fastapi import APIRouter, Path, Request

from dronefleet.ground.manager.context import Operator, audited
from dronefleet.ground.manager.errors import answers
from dronefleet.ground.planner import drone_ops
from dronefleet.ground.planner.api import planner_of
from dronefleet.ground.planner.models import MissionRecord
from dronefleet.ground.planner.schemas import MissionSummary
from dronefleet.ground.planner.service import MissionPlanner

router = APIRouter(
    prefix="/api/v1/drones", tags=["drones"], responses=answers(401, 403, 409, 422, 503)
)
DroneId = Annotated[
    str, Path(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_\-]+$", description="drone id")
]
Action = Callable[[MissionPlanner, str], Awaitable[MissionRecord]]


async def _act(
    request: Request, who: Operator, drone_id: str, command: str, action: Action
) -> MissionSummary:
    call = action(planner_of(request), drone_id)
    record = await audited(
        request, who, drone_id, command, {"drone_id": drone_id}, call,
        recorded=lambda r: {"mission_id": r.mission_id, "state": r.state.value},
    )  # fmt: skip
    return MissionSummary.model_validate(record.summary())


@router.post(
    "/{drone_id}/pause",
    summary="Pause this drone's mission leg: it holds and keeps its steps for a resume",
)
async def pause_drone(request: Request, who: Operator, drone_id: DroneId) -> MissionSummary:
    return await _act(request, who, drone_id, "drone.pause", drone_ops.pause_drone)


@router.post("/{drone_id}/resume", summary="Resume this drone's paused mission leg")
async def resume_drone(request: Request, who: Operator, drone_id: DroneId) -> MissionSummary:
    return await _act(request, who, drone_id, "drone.resume", drone_ops.resume_drone)


@router.post(
    "/{drone_id}/abort",
    summary="End this drone's part of its mission and send it home (RTL); the last drone of a "
    "mission aborts the mission",
)
async def abort_drone(request: Request, who: Operator, drone_id: DroneId) -> MissionSummary:
    return await _act(request, who, drone_id, "drone.abort", drone_ops.abort_drone)
