"""How the Drone Manager says no: one JSON shape, ``{"detail": "<reason>", ...}``, right status.

Unknown drone 404, lost drone 409 (with last-seen), invalid input 422 with the reason, no answer in
time 504. Anything a caller sends is answered with a 4xx; a 500 means a bug in this server.

Every refusal is a :class:`~dronefleet.errors.DronefleetError` and one handler answers them all
with the status its class carries. :class:`ApiError` is the one for the HTTP layer's own refusals
(401, 403, 415...) whose status is chosen where it is raised. :func:`answers` documents the same
shapes in the OpenAPI schema, so what is published is what is answered.
"""

from __future__ import annotations

import json
import logging
import re
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from pydantic import BaseModel, ConfigDict
from starlette.exceptions import HTTPException as StarletteHTTPException

from dronefleet.errors import (
    Conflict,
    DronefleetError,
    InvalidInput,
    NoAnswer,
    NotFound,
    Unavailable,
)

log = logging.getLogger(__name__)


class ApiError(DronefleetError):
    """An error answer with a status chosen where it is raised, a reason and extra fields."""

    def __init__(self, status: int, detail: str, /, **extra: Any) -> None:
        super().__init__(detail, **extra)
        self.status = status


#: The one place domain errors become HTTP statuses (docs/DESIGN.md §8): by their kind.
STATUS: dict[type[DronefleetError], int] = {
    InvalidInput: 422,
    NotFound: 404,
    Conflict: 409,
    Unavailable: 503,
    NoAnswer: 504,
}


def status_of(exc: DronefleetError) -> int:
    """The HTTP status ``exc`` is answered with; 500 for a kind with none (a bug if it escapes)."""
    if isinstance(exc, ApiError):
        return exc.status
    return next((STATUS[k] for k in type(exc).__mro__ if k in STATUS), 500)


# -- what the OpenAPI schema says about errors ---------------------------------------------------
class ErrorBody(BaseModel):
    """Every error answer: the reason, and fields that depend on the error (e.g. ``last_seen``)."""

    model_config = ConfigDict(extra="allow")
    detail: str


class FieldError(BaseModel):
    loc: list[str]
    msg: str
    type: str | None = None


class ValidationErrorBody(ErrorBody):
    """A request that does not fit the schema: the reasons joined, and each one by location."""

    errors: list[FieldError]


_WHY = {
    401: "missing or unknown API token",
    403: "the token's role is too low",
    404: "not found",
    405: "the command changes the drone: use POST",
    409: "conflicts with the current state (drone lost, busy, refused)",
    413: "request body too large (ground/manager/hardening.py)",
    415: "unsupported body type",
    422: "invalid input; `detail` says why",
    429: "too many failed authentications from this client; wait a minute",
    503: "a service it needs is unavailable",
    504: "no answer in time; a command may still reach the drone",
}


def answers(*statuses: int) -> dict[int | str, dict[str, Any]]:
    """The error answers a route can give, for its ``responses=`` (422 with its real shape).

    FastAPI would otherwise publish its own 422 schema (``detail`` a list), which is not what
    :func:`install` answers.
    """
    # Every route behind a token may also refuse a client that failed too often (429) and a
    # body too large (413), before the route runs.
    guarded = (*statuses, 413, 429) if 401 in statuses else statuses
    return {
        status: {
            "model": ValidationErrorBody if status == 422 else ErrorBody,
            "description": _WHY.get(status, "error"),
        }
        for status in guarded
    }


def validation_reason(errors: list[Any]) -> str:
    """``query.lat: Input should be less than or equal to 90; body: Field required``."""
    parts = []
    for err in errors:
        loc = ".".join(str(p) for p in err.get("loc", ()))
        parts.append(f"{loc}: {err.get('msg', 'invalid')}" if loc else str(err.get("msg")))
    return "; ".join(parts) or "invalid request"


def _jsonable_errors(errors: list[Any]) -> list[dict[str, Any]]:
    return [
        {"loc": [str(p) for p in e.get("loc", ())], "msg": str(e.get("msg")), "type": e.get("type")}
        for e in errors
    ]


#: Paths whose requests are commands: rejected ones are audited too.
_COMMAND_PATH = re.compile(r"^/api/v1/drones/([^/]+)/(commands/([^/]+)|mission(/stop)?)$")
#: The mission requests the planner audits (planner/api.py), by path: refused ones are too.
_MISSION_COMMANDS = {
    "/api/v1/missions": "mission.create",
    "/api/v1/missions/preview": "mission.preview",
    "/api/v1/missions/preflight": "mission.preflight",
}
#: What of a refused request's answer the audit keeps: the reason and the first field errors.
_AUDITED_ERRORS = 20


def _audited_path(path: str) -> bool:
    return path in _MISSION_COMMANDS or _COMMAND_PATH.match(path) is not None


async def _sent(request: Request) -> Any:
    """The request's JSON body as the route read it (Python's json: ``1e400`` is infinity, a
    30-digit integer an int), or its first 500 characters when it is not JSON."""
    raw = await request.body()
    try:
        return json.loads(raw)
    except ValueError:
        return {"raw": raw[:500].decode("utf-8", "replace")}


def _excerpt(value: Any) -> Any:
    """A field of a refused mission, bounded for its audit row."""
    if isinstance(value, str):
        return value[:200]
    if isinstance(value, list):
        return [_excerpt(v) for v in value[:50]]
    return value if isinstance(value, int | float | bool) or value is None else str(value)[:200]


async def _audit_rejected(request: Request, body: dict[str, Any]) -> None:
    """Audit a command or mission request FastAPI refused before our route ran (its body did
    not fit its schema: a field of the wrong type, a number out of range)."""
    from dronefleet.ground.manager.auth import Role

    path = request.url.path
    ctx = request.app.state.ctx
    try:
        who = await ctx.tokens.principal(request, Role.OPERATOR)
    except ApiError:
        return
    answer = {**body, "errors": body.get("errors", [])[:_AUDITED_ERRORS]}
    sent = await _sent(request)
    if path in _MISSION_COMMANDS:
        # What the route itself records (planner/api.py), from what was sent; not the steps.
        fields = sent if isinstance(sent, dict) else {}
        params = {k: _excerpt(fields[k]) for k in ("name", "drones", "raw") if k in fields}
        params |= {k: _excerpt(v) for k, v in request.query_params.items()}
        await ctx.gateway.audit(who, None, _MISSION_COMMANDS[path], params, 422, answer)
        return
    match = _COMMAND_PATH.match(path)
    assert match is not None  # _audited_path
    command = match[3] or ("stopchain" if match[4] else "startchain")
    params = sent if isinstance(sent, dict) else {"body": sent}
    await ctx.gateway.audit(who, match[1], command, params, 422, answer)


def error_body(status: int, body: dict[str, Any]) -> dict[str, Any]:
    """Every 422 has ``errors`` (its schema says so): a refusal found past the request's schema
    (a polygon that crosses itself, an unknown step) is one error without a location."""
    if status == 422 and "errors" not in body:
        return {**body, "errors": [{"loc": [], "msg": body["detail"], "type": "invalid_input"}]}
    return body


def install(app: FastAPI) -> None:
    # The one mapping of domain errors to HTTP: STATUS, by the error's kind.
    @app.exception_handler(DronefleetError)
    async def _refused(request: Request, exc: DronefleetError) -> JSONResponse:
        status = status_of(exc)
        if status == 500:
            log.error("unmapped error on %s", request.url.path, exc_info=exc)
        return JSONResponse(error_body(status, exc.body()), status_code=status)

    @app.exception_handler(RequestValidationError)
    async def _invalid(request: Request, exc: RequestValidationError) -> JSONResponse:
        errors = list(exc.errors())
        body: dict[str, Any] = {
            "detail": validation_reason(errors),
            "errors": _jsonable_errors(errors),
        }
        if request.method == "POST" and _audited_path(request.url.path):
            await _audit_rejected(request, body)
        return JSONResponse(body, status_code=422)

    @app.exception_handler(StarletteHTTPException)
    async def _http(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        detail = exc.detail if isinstance(exc.detail, str) else str(exc.detail)
        # FastAPI's 400 is a body it could not parse (not UTF-8, say): input the server cannot
        # use, which everywhere else is a 422, so one status and one shape for all of it.
        status = 422 if exc.status_code == 400 else exc.status_code
        body = error_body(
            status, {"detail": f"body: {detail}" if status != exc.status_code else detail}
        )
        return JSONResponse(body, status_code=status, headers=exc.headers)
