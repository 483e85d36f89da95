"""Audit log (seed requirement 3.1.6) and API tokens: who may do what, and who did what."""

from typing import Annotated, Any

from fastapi import APIRouter, Path, Query, Request
from pydantic import BaseModel, ConfigDict, Field

from dronefleet.ground.manager.auth import Role
from dronefleet.ground.manager.context import Admin, Operator, ctx_of
from dronefleet.ground.manager.errors import ApiError, answers
from dronefleet.ground.manager.schemas import AuditEntry, NewTokenAnswer, Revoked, TokenInfo

router = APIRouter(prefix="/api/v1", tags=["admin"], responses=answers(401, 403, 422))
#: The largest id SQLite stores (a signed 64-bit integer).
MAX_ROW_ID = 2**63 - 1

TokenName = Annotated[str, Path(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.\-]+$")]


@router.get(
    "/audit",
    summary="Every command sent: who, when, what, and the answer",
    response_model=list[AuditEntry],
)
async def read_audit(
    request: Request,
    who: Operator,
    drone: Annotated[str | None, Query(max_length=64)] = None,
    limit: Annotated[int, Query(ge=1, le=10_000)] = 100,
    before_id: Annotated[int | None, Query(ge=1, le=MAX_ROW_ID)] = None,
) -> list[dict[str, Any]]:
    return await ctx_of(request).state.read_audit(drone_id=drone, limit=limit, before_id=before_id)


class NewToken(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str = Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.\-]+$")
    role: str = Field(pattern=r"^(viewer|operator|admin)$")


@router.get(
    "/tokens",
    summary="API tokens (names and roles; never the tokens themselves)",
    response_model=list[TokenInfo],
)
async def list_tokens(request: Request, who: Admin) -> list[dict[str, Any]]:
    return await ctx_of(request).state.list_tokens()


@router.post(
    "/tokens",
    summary="Create or replace a named token; the token is shown only once",
    response_model=NewTokenAnswer,
)
async def create_token(request: Request, who: Admin, body: NewToken) -> dict[str, Any]:
    role = Role.parse(body.role)
    token = await ctx_of(request).tokens.issue(body.name, role)
    return {"name": body.name, "role": role.label, "token": token}


@router.delete(
    "/tokens/{name}", summary="Revoke a token", responses=answers(404), response_model=Revoked
)
async def delete_token(request: Request, who: Admin, name: TokenName) -> dict[str, Any]:
    if not await ctx_of(request).tokens.revoke(name):
        raise ApiError(404, f"no token named {name!r}")
    return {"name": name, "revoked": True}
