"""Sign in and out of the web app (issue 12): a token exchanged once for an HttpOnly session.

``POST /api/v1/session`` with ``Authorization: Bearer <token>`` sets the session cookie (see
``session.py``) and answers who signed in; ``DELETE /api/v1/session`` ends it. The page never
keeps the token: the demo's sign-in link ``/?token=...`` is read once, taken out of the address
bar and exchanged here.
"""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Depends, Request, Response

from dronefleet.ground.manager.auth import Role, hash_token, token_from
from dronefleet.ground.manager.context import BEARER, Viewer, ctx_of
from dronefleet.ground.manager.errors import ApiError, answers
from dronefleet.ground.manager.schemas import Me
from dronefleet.ground.manager.session import SESSION_COOKIE

router = APIRouter(prefix="/api/v1", tags=["web"])


def _me(name: str, role: Role) -> dict[str, Any]:
    return {"name": name, "role": role.label, "can_command": role >= Role.OPERATOR}


@router.post(
    "/session",
    summary="Sign the web app in: a token in, an HttpOnly session cookie out",
    responses=answers(401, 429),
    response_model=Me,
)
async def sign_in(
    request: Request,
    response: Response,
    _declared: Annotated[object, Depends(BEARER)] = None,  # the token, shown in the OpenAPI
) -> dict[str, Any]:
    token = token_from(request)
    if not token:
        raise ApiError(401, "sign in with 'Authorization: Bearer <token>'")
    tokens = ctx_of(request).tokens
    who = await tokens.by_token(request, token)
    session = await tokens.sessions.open(hash_token(token))
    response.set_cookie(
        SESSION_COOKIE,
        session,
        max_age=int(tokens.sessions.ttl_s),
        path="/",
        httponly=True,
        samesite="strict",
        secure=request.url.scheme == "https",
    )
    await ctx_of(request).state.audit(
        who=who.name, role=who.role.label, drone_id=None, command="sign-in", params={},
        status=200, answer={},
    )  # fmt: skip
    return _me(who.name, who.role)


@router.delete(
    "/session",
    summary="Sign the web app out: the session ends and its cookie is cleared",
    responses=answers(401),
    status_code=204,
)
async def sign_out(request: Request, who: Viewer) -> Response:
    session = request.cookies.get(SESSION_COOKIE)
    if session:
        await ctx_of(request).tokens.sessions.close(session)
    response = Response(status_code=204)
    response.delete_cookie(SESSION_COOKIE, path="/", httponly=True, samesite="strict")
    return response
