"""What every Drone Manager route needs, gathered once and kept on ``app.state.ctx``."""

from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Annotated, Any

from fastapi import Depends, Request
from fastapi.security import APIKeyCookie, HTTPBearer
from starlette.requests import HTTPConnection

from dronefleet.errors import DronefleetError, NoAnswer
from dronefleet.ground.manager.auth import Principal, Role, TokenBook
from dronefleet.ground.manager.errors import status_of
from dronefleet.ground.manager.gateway import DroneGateway
from dronefleet.ground.manager.session import SESSION_COOKIE
from dronefleet.ground.state import StateStore
from dronefleet.ground.telemetry.store import TelemetryStore
from dronefleet.messaging.rpc import RequestTimeout


@dataclass
class ManagerContext:
    state: StateStore
    tokens: TokenBook
    gateway: DroneGateway
    telemetry: TelemetryStore
    hub: Any  # StreamHub (kept loose to avoid an import cycle)


def ctx_of(conn: HTTPConnection) -> ManagerContext:
    return conn.app.state.ctx


#: The API's security scheme as OpenAPI shows it (issue 12: clients and fuzzers see it): a bearer
#: token in ``Authorization``. FastAPI's HTTPBearer only declares it here (``auto_error=False``);
#: the token is checked by the TokenBook, which answers 401/403/429 with the reason.
BEARER = HTTPBearer(auto_error=False, description="an API token: `Authorization: Bearer <token>`")
#: The web app's alternative: the HttpOnly session cookie that ``POST /api/v1/session`` sets.
SESSION = APIKeyCookie(
    name=SESSION_COOKIE,
    auto_error=False,
    description="the web app's sign-in session (set by POST /api/v1/session); changes also "
    "need the X-Requested-With header",
)


def _needs(role: Role) -> Callable[..., Awaitable[Principal]]:
    async def dependency(
        request: Request,
        _declared: Annotated[object, Depends(BEARER)] = None,
        _session: Annotated[object, Depends(SESSION)] = None,
    ) -> Principal:
        return await ctx_of(request).tokens.principal(request, role)

    return dependency


viewer = _needs(Role.VIEWER)
operator = _needs(Role.OPERATOR)
admin = _needs(Role.ADMIN)
#: Route parameter types: ``who: Operator`` checks the token and gives the caller.
Viewer = Annotated[Principal, Depends(viewer)]
Operator = Annotated[Principal, Depends(operator)]
Admin = Annotated[Principal, Depends(admin)]


async def audited(
    request: Request,
    who: Principal,
    drone_id: str | None,
    command: str,
    params: dict[str, Any],
    call: Awaitable[Any],
    *,
    recorded: Callable[[Any], Any] = lambda answer: answer,
    silent: str = "no answer",
) -> Any:
    """Await ``call`` and write the outcome, good or bad, to the audit log: the one audit
    wrapper of every command and planner call. ``recorded`` is what of a good answer is kept;
    a request nobody answered (``silent`` says who) is a 504."""
    gateway = ctx_of(request).gateway
    try:
        answer = await call
    except RequestTimeout as exc:
        error = NoAnswer(f"{silent}: {exc}")
        await gateway.audit(who, drone_id, command, params, status_of(error), error.body())
        raise error from exc
    except DronefleetError as exc:
        await gateway.audit(who, drone_id, command, params, status_of(exc), exc.body())
        raise
    await gateway.audit(who, drone_id, command, params, 200, recorded(answer))
    return answer
