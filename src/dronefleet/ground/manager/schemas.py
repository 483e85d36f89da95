"""What the manager's routes answer, as named models, so ``/openapi.json`` names a schema for
every 2xx response (issue 15; schemathesis checks the answers against them in ``make test``).

The answers are built as dicts (by the Drone Identifier, the drones, the stores); these models
describe them without changing them: the fields every client reads are typed, and ``extra`` is
allowed where a part is open by design (a flight-controller object's fields, a step's result,
the gear files of Listing 4.2), so a drone that says more is not an error of ours.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, RootModel


class _Open(BaseModel):
    model_config = ConfigDict(extra="allow")


class Drone(_Open):
    """One drone as the Drone Identifier knows it (seed Fig. 4.21, plus liveness)."""

    drone_id: str
    status: str
    last_seen: float | None = None
    seen_ago_s: float | None = None
    first_seen: float | None = None
    heartbeat_interval_s: float | None = None
    position: dict[str, Any] | None = None
    home: dict[str, Any] | None = None
    battery: dict[str, Any] | None = None
    state: str | None = None
    mode: str | None = None
    mission_id: str | None = None
    step_index: int | None = None
    flight: dict[str, Any] | None = None
    ground_speed_mps: float | None = None
    gps: dict[str, Any] | None = Field(default=None, description="fix and satellites")
    wind: dict[str, Any] | None = Field(
        default=None, description="the autopilot's wind estimate; absent: unknown"
    )
    link_failsafe: dict[str, Any] | None = Field(
        default=None,
        description="what its autopilot does by itself when the drone's software falls silent"
        " (action: off, rtl, land...; timeout_s; set_by_drone); absent: no such autopilot",
    )
    vehicle_time_s: float | None = None
    specs: dict[str, Any] | None = None
    sensors: dict[str, Any] | None = None


class Gear(_Open):
    """A drone's specifications and sensors (seed: getgear; Listing 4.2)."""

    drone_id: str
    specs: dict[str, Any] | None = None
    sensors: dict[str, Any] | None = None


class CommandAnswer(_Open):
    """A Drone Controller's answer to a control command (``control/out``)."""

    request_id: str | None = None
    drone_id: str | None = None
    command: str | None = None
    ok: bool
    error: str | None = None
    result: dict[str, Any] | None = None
    done: bool | None = Field(
        default=None,
        description="false: a move under way; the drone reports its end with the same "
        "request_id on the live stream (kind 'command', done true, outcome)",
    )
    outcome: str | None = None
    timestamp: float | None = None
    vehicle_time_s: float | None = None


class MissionAnswer(_Open):
    """A Mission Worker's first report on a mission request (``mission/out``)."""

    drone_id: str | None = None
    mission_id: str | None = None
    request_id: str | None = None
    event: str | None = None
    ok: bool | None = None
    error: str | None = None
    step_count: int | None = None
    result: dict[str, Any] | None = None
    vehicle_time_s: float | None = None


class Telemetry(BaseModel):
    """One drone's telemetry over a time range: per field, [unix seconds, value] pairs."""

    model_config = ConfigDict(populate_by_name=True)

    drone: str
    from_: float = Field(alias="from")
    to: float
    every_s: float
    fields: list[str]
    series: dict[str, list[list[float | None]]]


class AuditEntry(BaseModel):
    id: int
    ts: float
    who: str | None = None
    role: str | None = None
    drone_id: str | None = None
    command: str | None = None
    params: Any = None
    status: int | None = None
    answer: Any = None


class TokenInfo(BaseModel):
    name: str
    role: str
    created_at: float | None = None


class NewTokenAnswer(BaseModel):
    name: str
    role: str
    token: str


class Revoked(BaseModel):
    name: str
    revoked: bool


class WebConfig(BaseModel):
    tiles: str | None = Field(default=None, description="the map's tile URL template, or none")
    local_tiles: bool = Field(
        default=False, description="tiles from this ground's MBTiles file: ask with credentials"
    )


class Binary(RootModel[str]):
    """A file's bytes, not JSON: an image (a map tile, a picture) or a zip."""

    model_config = ConfigDict(json_schema_extra={"format": "binary"})


def binary(*media_types: str) -> dict[int | str, dict[str, Any]]:
    """A route's 200 as files of these media types, with a named schema (issue 15)."""
    schema = {"schema": {"$ref": "#/components/schemas/Binary"}}
    return {200: {"model": Binary, "content": {media: schema for media in media_types}}}


class Me(BaseModel):
    name: str
    role: str
    can_command: bool


class HealthProblem(BaseModel):
    what: str = Field(description="disk, broker, planner, state or telemetry")
    detail: str = Field(description="what is wrong, in a sentence")


class Partition(BaseModel):
    """This replica's part of a fleet shared by drone (``--partition-fleet``)."""

    replicas: int = Field(description="the live replicas sharing the fleet, this one included")
    drones: int = Field(description="drones heard (every replica hears every heartbeat)")
    own: int = Field(description="those whose telemetry this replica takes from the broker")
    moved: int = Field(
        description="drones this replica took over or gave up since it started, as replicas "
        "came and went (a replica dropping out and back, on a host too loaded to renew, shows "
        "here)"
    )


class Health(BaseModel):
    """The ground's health (ground/manager/health.py): 200 ``ok``, or 503 ``degraded`` with
    the problems while any lasts."""

    ok: bool
    status: Literal["ok", "degraded"] = "ok"
    problems: list[HealthProblem] = Field(default_factory=list)
    replica: Literal["leader", "standby"] | None = Field(
        default=None,
        description="among ground replicas sharing a PostgreSQL state: leader (runs the "
        "Mission Planner) or standby; none for a ground alone on its broker",
    )
    partition: Partition | None = Field(
        default=None, description="with --partition-fleet: this replica's part of the fleet"
    )
    version: str
    dropped_messages: dict[str, int] = Field(
        default_factory=dict,
        description="broker messages the ground refused since it started, by kind: malformed, "
        "or about another drone than their topic's (counted, never acted upon)",
    )


class MissionLog(_Open):
    """The mission log (format ``dronefleet-mission-log/1``): per drone, every step it flew and
    the path it flew; the handovers and extensions; the mission's timing."""

    format: str
    mission_id: str
    name: str | None = None
    state: str
    drones: list[dict[str, Any]]
