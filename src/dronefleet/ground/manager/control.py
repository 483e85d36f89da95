"""The seed's ``/control`` endpoint, exactly as Table 4.2, for clients written against the seed.

``GET|POST /control?command=arm&droneID=QUAD_REVO2`` (parameters in the query string, a form body
or a JSON body): ``discover``, ``getgear`` and ``objrequest`` read and work with GET or POST; every
other command changes the drone and needs POST. ``startchain`` takes the base64 ``mission``;
``startchain``/``stopchain`` go to the drone's mission path (the Mission Planner sits there later).
"""

from secrets import token_hex
from typing import Any
from urllib.parse import parse_qsl

import orjson
from fastapi import APIRouter, Request
from pydantic import ValidationError

from dronefleet.ground.manager.auth import Role
from dronefleet.ground.manager.context import ctx_of
from dronefleet.ground.manager.drones import MIN_TIMEOUT_S, gear_of, run_control, run_mission
from dronefleet.ground.manager.errors import ApiError, answers
from dronefleet.ground.manager.schemas import CommandAnswer, Drone, Gear, MissionAnswer
from dronefleet.messaging.commands import CONTROL_COMMANDS, Command
from dronefleet.messaging.common import reason
from dronefleet.messaging.missions import MissionAction, MissionRequest

router = APIRouter(tags=["seed"])

READS = {"discover", "getgear", Command.OBJREQUEST.value}
MISSION = {"startchain", "stopchain"}
KNOWN = sorted(READS | MISSION | {c.value for c in CONTROL_COMMANDS})
#: Table 4.2's parameters, plus ``force`` (disarm/resetfc in flight) and our ``timeout_s``.
PARAMS = {"command", "droneID", "value", "lat", "lon", "altitude_delta", "mission", "force"}
EXTRA = {"token", "timeout_s", "mission_id"}


async def _params(request: Request) -> dict[str, str]:
    params: dict[str, Any] = dict(request.query_params)
    body = await request.body()
    if request.method == "POST" and body:
        kind = request.headers.get("content-type", "").split(";")[0].strip().lower()
        if kind == "application/json":
            try:
                data = orjson.loads(body)
            except orjson.JSONDecodeError as exc:
                raise ApiError(422, f"body is not valid JSON: {exc}") from exc
            if not isinstance(data, dict):
                raise ApiError(422, "a JSON body must be an object of parameters")
            params.update(data)
        elif kind in {"application/x-www-form-urlencoded", ""}:
            try:
                params.update(parse_qsl(body.decode("utf-8"), keep_blank_values=True))
            except UnicodeDecodeError as exc:
                raise ApiError(422, "form body is not UTF-8") from exc
        else:
            raise ApiError(415, f"unsupported body type {kind!r}: use a form or JSON")
    unknown = sorted(set(params) - PARAMS - EXTRA)
    if unknown:
        raise ApiError(422, f"unknown parameter(s): {', '.join(unknown)}")
    # HTML forms send empty optional fields: treat them as absent.
    return {k: v for k, v in params.items() if v not in ("", None)}


def _timeout(params: dict[str, Any]) -> float | None:
    if "timeout_s" not in params:
        return None
    try:
        value = float(params["timeout_s"])
    except (TypeError, ValueError) as exc:
        raise ApiError(422, "timeout_s: must be a number of seconds") from exc
    if not MIN_TIMEOUT_S <= value <= 300:
        raise ApiError(422, f"timeout_s: must be in [{MIN_TIMEOUT_S:g}, 300]")
    return value


#: Parameters come from the query, a form or a JSON body (read by hand, as the seed allowed),
#: so only the answers are documented: every refusal the drone routes give, and 405/415.
_ANSWERS = answers(401, 403, 404, 405, 409, 415, 422, 504)
#: discover: the fleet; getgear: the gear; a command: its answer; a mission: its first report.
ControlAnswer = list[Drone] | Gear | CommandAnswer | MissionAnswer


@router.get(
    "/control",
    summary="The seed's control endpoint (reads)",
    operation_id="control_get",
    responses=_ANSWERS,
    response_model=ControlAnswer,
    response_model_exclude_unset=True,
)
@router.post(
    "/control",
    summary="The seed's control endpoint",
    operation_id="control_post",
    responses=_ANSWERS,
    response_model=ControlAnswer,
    response_model_exclude_unset=True,
)
async def control(request: Request) -> Any:
    params = await _params(request)
    command = params.get("command")
    if not isinstance(command, str) or command not in KNOWN:
        raise ApiError(422, f"command: unknown or missing {command!r}; known: {', '.join(KNOWN)}")
    ctx = ctx_of(request)
    need = Role.VIEWER if command in READS else Role.OPERATOR
    who = await ctx.tokens.principal(request, need)
    if command not in READS and request.method != "POST":
        raise ApiError(405, f"{command} changes the drone: use POST")
    if command == "discover":
        return await ctx.gateway.fleet()
    drone_id = params.get("droneID")
    if not isinstance(drone_id, str):
        raise ApiError(422, f"droneID: required for {command}")
    timeout_s = _timeout(params)
    if command == "getgear":
        return await gear_of(ctx.gateway, drone_id, timeout_s)
    if command in MISSION:
        mission = params.get("mission")
        try:
            if command == "startchain":
                message = MissionRequest(
                    mission_id=str(params.get("mission_id") or f"{drone_id}-{token_hex(4)}"),
                    mission=mission if isinstance(mission, str) else None,
                    steps=mission if isinstance(mission, list) else None,
                )
            else:
                message = MissionRequest(action=MissionAction.STOP)
        except ValidationError as exc:
            raise ApiError(422, reason(exc)) from exc
        return await run_mission(request, who, drone_id, message, timeout_s)
    control_params = {k: v for k, v in params.items() if k in PARAMS - {"droneID", "mission"}}
    return await run_control(request, who, drone_id, control_params, timeout_s)
