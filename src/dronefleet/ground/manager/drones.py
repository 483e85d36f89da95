"""Resource-style drone routes: the fleet, one drone, its gear and objects, commands, missions.

``POST /api/v1/drones/{id}/commands/{command}`` has one route per control command of seed
Table 4.2, each with its own typed body (the messaging model's parameters), so the OpenAPI docs
show exactly what each command takes.
"""

import inspect
import secrets
import typing
from typing import Annotated, Any

import orjson
from fastapi import APIRouter, Body, Path, Query, Request, Response
from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError, create_model

from dronefleet.ground.manager.auth import Principal
from dronefleet.ground.manager.context import Operator, Viewer, audited, ctx_of
from dronefleet.ground.manager.errors import ApiError, answers
from dronefleet.ground.manager.gateway import DroneGateway
from dronefleet.ground.manager.schemas import CommandAnswer, Drone, Gear, MissionAnswer
from dronefleet.ground.planner import direct_checks
from dronefleet.messaging.codec import MessageError
from dronefleet.messaging.commands import CONTROL_COMMANDS, Command, ControlRequest, parse_control
from dronefleet.messaging.gear import GearQuery, GearRequest
from dronefleet.messaging.missions import MAX_STEPS, MissionAction, MissionRequest, decode_steps

# Every drone route needs a token and names a drone the Identifier may not know or may have
# lost; the answer comes over the broker, so it may not come in time (504).
router = APIRouter(
    prefix="/api/v1/drones", tags=["drones"], responses=answers(401, 403, 404, 409, 422, 504)
)

DroneId = Annotated[str, Path(min_length=1, max_length=64, description="drone identifier")]
#: Shortest wait for a drone's answer. A timeout is no cancellation: the command goes out all the
#: same and a 504 says only that no answer came in time. Below a broker's round trip every
#: command would be a 504 that still flies (issue 11: ``timeout_s=5e-324``).
MIN_TIMEOUT_S = 0.1
Timeout = Annotated[
    float | None,
    Query(
        ge=MIN_TIMEOUT_S,
        le=300,
        description="seconds to wait for the drone's answer (the command is sent either way)",
    ),
]
_HIDDEN = {"command", "request_id", "sender"}
#: Flight commands a drone refuses while a mission flies it unless forced (drone/
#: direct_commands.py), whose message models have no ``force`` of their own (disarm and resetfc
#: have): the ground takes it from the body and sends it along.
FORCEABLE = frozenset(
    {
        Command.TAKEOFF,
        Command.NAVIGATE,
        Command.CHANGE_N,
        Command.CHANGE_E,
        Command.ALTITUDE,
        Command.MODE,  # GUIDED (the stopping modes are always obeyed; force changes nothing)
    }
)
FORCE_DOC = (
    "fly it even while a mission flies this drone: the mission is paused first (resume it "
    "from the ground); audited with who forced it. Without it such a command is refused (409) "
    "until the mission is paused or aborted"
)
_FLAG: TypeAdapter[bool] = TypeAdapter(bool)
JSON = "application/json"


@router.get(
    "",
    summary="List every drone the Drone Identifier knows (seed: discover)",
    response_model=list[Drone],
    response_model_exclude_unset=True,
)
async def list_drones(request: Request, who: Viewer) -> Response:
    # The records already have the Drone shape (ground/fleet.py, DroneRecord.public): FastAPI's
    # validating them again against ``list[Drone]`` on every request cost 100 ms of CPU at
    # 1000 drones, 18 % of a loaded ground's event loop (issue 27), so the answer is sent as
    # it is; the response model stays for the OpenAPI schema, and
    # tests/unit/ground/test_drone_list_answer.py holds the two to the same JSON.
    return Response(orjson.dumps(await ctx_of(request).gateway.fleet()), media_type=JSON)


@router.get(
    "/{drone_id}",
    summary="One drone: position, battery, state, gear, liveness",
    response_model=Drone,
    response_model_exclude_unset=True,
)
async def get_drone(request: Request, who: Viewer, drone_id: DroneId) -> dict[str, Any]:
    return await ctx_of(request).gateway.drone(drone_id)


@router.get(
    "/{drone_id}/gear",
    summary="Specifications and sensors (seed: getgear)",
    response_model=Gear,
    response_model_exclude_unset=True,
)
async def get_gear(
    request: Request, who: Viewer, drone_id: DroneId, timeout_s: Timeout = None
) -> dict[str, Any]:
    return await gear_of(ctx_of(request).gateway, drone_id, timeout_s)


async def gear_of(gateway: DroneGateway, drone_id: str, timeout_s: float | None) -> dict[str, Any]:
    """A drone's specs and sensors: the Identifier's copy, or the Gear Manager's answer when
    the Identifier has not heard them yet. The one gear path, for this route and the seed's
    ``getgear`` on ``/control`` (which answered ``null`` where this one asked the drone)."""
    record = await gateway.drone(drone_id)
    gear = {"drone_id": drone_id, "specs": record.get("specs"), "sensors": record.get("sensors")}
    for query in (GearQuery.SPECS, GearQuery.SENSORS):
        if gear[query.value] is None:  # not heard yet: ask the Gear Manager now
            answer = await gateway.gear(drone_id, GearRequest(query=query), timeout_s)
            gear[query.value] = answer.get(query.value)
    return gear


@router.get(
    "/{drone_id}/objects/{name}",
    summary="Request a flight-controller object",
    response_model=CommandAnswer,
    response_model_exclude_unset=True,
)
async def get_object(
    request: Request,
    who: Viewer,
    drone_id: DroneId,
    name: Annotated[str, Path(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.\-]+$")],
    timeout_s: Timeout = None,
) -> dict[str, Any]:
    params = {"command": Command.OBJREQUEST.value, "value": name}
    return await run_control(request, who, drone_id, params, timeout_s)


async def run_control(
    request: Request,
    who: Principal,
    drone_id: str,
    params: dict[str, Any],
    timeout_s: float | None,
) -> dict[str, Any]:
    """Validate a control request, check a move as the planner checks a mission's step
    (ground/planner/direct_checks.py), send it with who sent it, wait for the answer; audited
    either way (a forced command with its ``force``)."""
    gateway = ctx_of(request).gateway
    planner = getattr(request.app.state, "planner", None)

    async def call() -> dict[str, Any]:
        wire = dict(params)
        forced = False
        if wire.get("command") in FORCEABLE and "force" in wire:
            try:
                forced = _FLAG.validate_python(wire.pop("force"))
            except ValidationError as exc:
                raise ApiError(422, "force: must be true or false") from exc
        try:
            parsed = parse_control(wire)
        except MessageError as exc:
            raise ApiError(422, str(exc)) from exc
        if planner is not None and parsed.command in direct_checks.CHECKED:
            record = await gateway.online_drone(drone_id)
            direct_checks.check_move(
                parsed,
                record,
                max_altitude_m=planner.max_altitude_m,
                reserve_pct=planner.reserve_pct,
                fence=direct_checks.fence_of(planner, drone_id),
            )
        extra: dict[str, Any] = {"sender": who.name[:128]}
        if forced:
            extra["force"] = True
        return await gateway.control(drone_id, parsed, timeout_s, extra)

    command = str(params.get("command"))
    return await audited(request, who, drone_id, command, params, call())


# -- one route per control command ---------------------------------------------------------------
def _body_model(model: type[BaseModel]) -> type[BaseModel]:
    fields: dict[str, Any] = {
        name: (info.annotation, info)
        for name, info in model.model_fields.items()
        if name not in _HIDDEN
    }
    command = typing.get_args(model.model_fields["command"].annotation)[0]
    if command in FORCEABLE and "force" not in fields:
        fields["force"] = (bool, Field(default=False, description=FORCE_DOC))
    # Strict: a JSON body says what it means (``"force": 0`` is not ``false``), as published.
    config = ConfigDict(extra="forbid", strict=True)
    return create_model(f"{model.__name__}Body", __config__=config, **fields)


def _add_command_route(command: Command, body_model: type[BaseModel], doc: str) -> None:
    required = any(f.is_required() for f in body_model.model_fields.values())

    async def handler(
        *,
        request: Request,
        who: Operator,
        drone_id: DroneId,
        body: Any = None,
        timeout_s: Timeout = None,
    ) -> dict[str, Any]:
        params = {"command": command.value}
        if body is not None:
            params.update(body.model_dump(exclude_none=True))
        return await run_control(request, who, drone_id, params, timeout_s)

    # The body's type is only known here: give FastAPI a signature that says it.
    sig = inspect.signature(handler)
    body_param = sig.parameters["body"].replace(
        annotation=body_model if required else body_model | None,
        default=Body(...) if required else Body(None),
    )
    handler.__signature__ = sig.replace(  # type: ignore[attr-defined]
        parameters=[body_param if p.name == "body" else p for p in sig.parameters.values()]
    )
    router.post(
        f"/{{drone_id}}/commands/{command.value}",
        summary=f"Command: {command.value}",
        description=doc,
        name=f"command_{command.value}",
        response_model=CommandAnswer,
        response_model_exclude_unset=True,
    )(handler)


for _model in typing.get_args(typing.get_args(ControlRequest)[0]):
    _cmd = Command(typing.get_args(_model.model_fields["command"].annotation)[0])
    if _cmd in CONTROL_COMMANDS:
        _add_command_route(_cmd, _body_model(_model), (_model.__doc__ or "").strip())


@router.post("/{drone_id}/commands/{command}", include_in_schema=False)
async def unknown_command(who: Operator, drone_id: str, command: str) -> None:
    known = ", ".join(sorted(CONTROL_COMMANDS))
    raise ApiError(404, f"unknown command {command!r}; known: {known}")


# -- missions ----------------------------------------------------------------------------------
class MissionStart(BaseModel):
    """A mission for one drone: the seed's base64 ``mission`` or plain JSON ``steps``."""

    model_config = ConfigDict(extra="forbid")
    mission_id: str = Field(default="", max_length=128, pattern=r"^[A-Za-z0-9_.\-]*$")
    mission: str | None = Field(
        default=None, max_length=10_000_000, description="base64 of a JSON list of steps"
    )
    steps: list[dict[str, Any]] | None = Field(default=None, max_length=10_000)
    # Past MAX_STEPS no step can be labelled; the bound also keeps it a 64-bit integer on the wire.
    start_index: int = Field(default=0, ge=0, le=MAX_STEPS)


async def run_mission(
    request: Request,
    who: Principal,
    drone_id: str,
    message: MissionRequest,
    timeout_s: float | None,
) -> dict[str, Any]:
    gateway = ctx_of(request).gateway

    async def call() -> dict[str, Any]:
        if message.action is MissionAction.START:
            try:
                decode_steps(message)
            except MessageError as exc:
                raise ApiError(422, str(exc)) from exc
        return await gateway.mission(drone_id, message, timeout_s)

    params = message.model_dump(mode="json", exclude_none=True)
    command = "startchain" if message.action is MissionAction.START else "stopchain"
    return await audited(request, who, drone_id, command, params, call())


@router.post(
    "/{drone_id}/mission",
    summary="Start a mission (seed: startchain)",
    response_model=MissionAnswer,
    response_model_exclude_unset=True,
)
async def start_mission(
    request: Request,
    who: Operator,
    drone_id: DroneId,
    body: MissionStart,
    timeout_s: Timeout = None,
) -> dict[str, Any]:
    mission_id = body.mission_id or f"{drone_id}-{secrets.token_hex(4)}"
    message = MissionRequest(
        mission_id=mission_id, mission=body.mission, steps=body.steps, start_index=body.start_index
    )
    return await run_mission(request, who, drone_id, message, timeout_s)


@router.post(
    "/{drone_id}/mission/stop",
    summary="Stop the running mission (seed: stopchain)",
    response_model=MissionAnswer,
    response_model_exclude_unset=True,
)
async def stop_mission(
    request: Request,
    who: Operator,
    drone_id: DroneId,
    timeout_s: Timeout = None,
) -> dict[str, Any]:
    message = MissionRequest(action=MissionAction.STOP)
    return await run_mission(request, who, drone_id, message, timeout_s)
