"""How the Drone Manager says no: one JSON shape, ``{"detail": "<reason>", ...}``, right status.

Unknown drone 404, lost drone 409 (with last-seen), invalid input 422 with the reason, no answer in
time 504. Anything a caller sends is answered with a 4xx; a 500 means a bug in this server.
"""

from __future__ import annotations

import logging
import re
from typing import Any

import orjson
from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

log = logging.getLogger(__name__)


class ApiError(Exception):
    """An error answer with a status, a reason and optional extra fields."""

    def __init__(self, status: int, detail: str, /, **extra: Any) -> None:
        super().__init__(detail)
        self.status = status
        self.detail = detail
        self.extra = extra

    def body(self) -> dict[str, Any]:
        return {"detail": self.detail, **self.extra}


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


async def _audit_rejected(request: Request, body: dict[str, Any]) -> None:
    """Audit a command FastAPI refused before our route ran (its body did not fit)."""
    from dronefleet.ground.manager.auth import Role

    match = _COMMAND_PATH.match(request.url.path)
    if match is None:
        return
    ctx = request.app.state.ctx
    try:
        who = await ctx.tokens.principal(request, Role.OPERATOR)
    except ApiError:
        return
    command = match[3] or ("stopchain" if match[4] else "startchain")
    try:
        params: Any = orjson.loads(await request.body())
    except orjson.JSONDecodeError:
        params = {"raw": (await request.body())[:500].decode("utf-8", "replace")}
    params = params if isinstance(params, dict) else {"body": params}
    await ctx.gateway.audit(who, match[1], command, params, 422, body)


def install(app: FastAPI) -> None:
    @app.exception_handler(ApiError)
    async def _api_error(request: Request, exc: ApiError) -> JSONResponse:
        return JSONResponse(exc.body(), status_code=exc.status)

    @app.exception_handler(RequestValidationError)
    async def _invalid(request: Request, exc: RequestValidationError) -> JSONResponse:
        errors = list(exc.errors())
        body = {"detail": validation_reason(errors), "errors": _jsonable_errors(errors)}
        if request.method == "POST" and _COMMAND_PATH.match(request.url.path):
            await _audit_rejected(request, body)
        return JSONResponse(body, status_code=422)

    @app.exception_handler(StarletteHTTPException)
    async def _http(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        detail = exc.detail if isinstance(exc.detail, str) else str(exc.detail)
        return JSONResponse({"detail": detail}, status_code=exc.status_code, headers=exc.headers)
