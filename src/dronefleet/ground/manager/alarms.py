"""``/api/v1/alarms``: the alarm centre's history and acknowledgements (issue 29).

``GET /api/v1/alarms`` lists what the alarm log (ground/alarm_log.py) kept, newest first or the
unacknowledged first, filtered by drone, level, time received and acknowledgement, with the count
of unacknowledged alarms under the same filter (the web's bell). ``GET /api/v1/alarms/latest``
gives each drone's newest alarm. ``POST /api/v1/alarms/{id}/ack`` acknowledges one as the caller
(an operator): written to the log and to the audit log, refused (409) when someone already did.
"""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Path, Query, Request
from pydantic import BaseModel, Field

from dronefleet.errors import Unavailable
from dronefleet.ground.alarm_log import AlarmFilter, AlarmLog
from dronefleet.ground.manager.context import Operator, Viewer, audited
from dronefleet.ground.manager.errors import ApiError, answers
from dronefleet.messaging.commands import AlarmLevel

router = APIRouter(prefix="/api/v1/alarms", tags=["alarms"], responses=answers(401, 403, 422, 503))

#: Most alarms one call lists.
MAX_LIMIT = 1_000
#: Timestamps the filters accept: Unix seconds up to the year 5138 (past it is a typo).
MAX_TIME_S = 1e11


class AlarmEntry(BaseModel):
    """One alarm as the ground received it, and its acknowledgement."""

    id: int
    received_at: float = Field(description="when the ground received it (Unix seconds)")
    drone_id: str
    level: str = Field(description="CRITICAL, OUT_MEASURE or WARNING")
    source: str = Field(description="drone: its own alarm; separation: the ground's monitor")
    message: str
    mission_id: str | None = None
    step_index: int | None = None
    position: dict[str, Any] | None = None
    reading: dict[str, Any] | None = None
    virtual: bool = False
    raised_at: float | None = Field(default=None, description="when the sender raised it")
    vehicle_time_s: float | None = None
    acknowledged: bool
    acked_at: float | None = None
    acked_by: str | None = Field(default=None, description="the token's name that acknowledged")


class AlarmPage(BaseModel):
    alarms: list[AlarmEntry]
    unacknowledged: int = Field(description="alarms not yet acknowledged under the same filter")
    next_before_id: int | None = Field(
        default=None, description="pass as before_id for the next (older) page; null: no more"
    )


def log_of(request: Request) -> AlarmLog:
    alarm_log = getattr(request.app.state, "alarms", None)
    if alarm_log is None:
        raise Unavailable("the alarm log is not running")
    return alarm_log


DroneFilter = Annotated[
    str | None,
    Query(
        min_length=1,
        max_length=64,
        pattern=r"^[A-Za-z0-9_\-]+$",
        description="only this drone's alarms",
    ),
]


@router.get("", summary="Alarm history: filter by drone, level, time; who acknowledged")
async def list_alarms(
    request: Request,
    who: Viewer,
    drone: DroneFilter = None,
    level: AlarmLevel | None = None,
    since: Annotated[
        float | None, Query(ge=0, le=MAX_TIME_S, description="received at or after (Unix s)")
    ] = None,
    until: Annotated[
        float | None, Query(ge=0, le=MAX_TIME_S, description="received at or before (Unix s)")
    ] = None,
    acknowledged: Annotated[
        bool | None, Query(description="true: only acknowledged; false: only open")
    ] = None,
    unacknowledged_first: Annotated[
        bool, Query(description="open alarms first, then the rest; each newest first")
    ] = False,
    limit: Annotated[int, Query(ge=1, le=MAX_LIMIT)] = 100,
    before_id: Annotated[int | None, Query(ge=1, le=2**63 - 1)] = None,
) -> AlarmPage:
    if since is not None and until is not None and since > until:
        raise ApiError(422, f"since ({since:g}) is after until ({until:g})")
    alarm_log = log_of(request)
    where = AlarmFilter(
        drone, level.value if level else None, since, until, acknowledged, before_id
    )
    alarms = await alarm_log.query(where, limit=limit, unacknowledged_first=unacknowledged_first)
    open_only = AlarmFilter(drone, where.level, since, until, False)
    more = len(alarms) == limit and not unacknowledged_first
    return AlarmPage(
        alarms=[AlarmEntry(**a) for a in alarms],
        unacknowledged=await alarm_log.count(open_only),
        next_before_id=alarms[-1]["id"] if more else None,
    )


@router.get("/latest", summary="Each drone's newest alarm")
async def latest_alarms(request: Request, who: Viewer) -> list[AlarmEntry]:
    return [AlarmEntry(**a) for a in await log_of(request).latest_per_drone()]


AlarmId = Annotated[int, Path(ge=1, le=2**63 - 1, description="the alarm's id in the log")]


@router.post(
    "/{alarm_id}/ack",
    summary="Acknowledge an alarm as the caller (audited)",
    responses=answers(404, 409),
)
async def acknowledge(request: Request, who: Operator, alarm_id: AlarmId) -> AlarmEntry:
    alarm_log = log_of(request)
    entry = await alarm_log.get(alarm_id)  # 404 before anything is written
    acked = await audited(
        request,
        who,
        entry["drone_id"],
        "ack_alarm",
        {"alarm_id": alarm_id, "level": entry["level"]},
        alarm_log.acknowledge(alarm_id, who.name),
        recorded=lambda answer: {"acked_at": answer["acked_at"], "acked_by": answer["acked_by"]},
    )
    return AlarmEntry(**acked)
