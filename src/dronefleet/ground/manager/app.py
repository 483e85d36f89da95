"""The Drone Manager's FastAPI application: routes, error shapes, OpenAPI docs at ``/docs``."""

from fastapi import FastAPI, Response

from dronefleet import __version__
from dronefleet.ground.manager import (
    admin,
    alarms,
    control,
    docs,
    drones,
    errors,
    maps,
    search,
    signin,
    stream,
    telemetry,
    web,
)
from dronefleet.ground.manager.context import ManagerContext
from dronefleet.ground.manager.hardening import Hardening
from dronefleet.ground.manager.schemas import Health

DESCRIPTION = """
The ground side of dronefleet: the Drone Manager (seed 4.2.3). Send commands to drones, start and
stop missions, read the fleet the Drone Identifier keeps, query stored telemetry, and follow it all
live on the `/api/v1/stream` WebSocket. Authenticate with `Authorization: Bearer <token>`
(or `X-API-Token: <token>`); the web app signs in once (`POST /api/v1/session`) and then holds
an HttpOnly session cookie.
"""


def create_app(ctx: ManagerContext) -> FastAPI:
    app = FastAPI(
        title="dronefleet ground",
        version=__version__,
        description=DESCRIPTION,
        redirect_slashes=False,  # a wrong path is a 404 with a reason, not a redirect
        docs_url=None,  # FastAPI's pages load from a CDN: manager/docs.py serves /docs offline
        redoc_url=None,
    )
    app.state.ctx = ctx
    errors.install(app)
    from dronefleet.ground.manager import separation
    from dronefleet.ground.photos import api as photos_api
    from dronefleet.ground.planner import api as planner_api
    from dronefleet.ground.planner import drone_api
    from dronefleet.ground.planner.files import api as files_api

    routers = (
        drones,
        control,
        telemetry,
        admin,
        alarms,
        stream,
        planner_api,
        files_api,
        photos_api,
    )
    for module in (*routers, drone_api, maps, search, separation, signin, web, docs):
        app.include_router(module.router)
    web.mount(app)
    app.add_middleware(Hardening)

    @app.get(
        "/api/v1/health",
        tags=["admin"],
        summary="Health of the ground services: 200 ok, or 503 degraded with the problems",
        response_model=Health,
        responses={503: {"model": Health, "description": "degraded: the problems say why"}},
    )
    async def health(response: Response) -> dict[str, object]:
        dropped = getattr(app.state, "dropped", None)
        probe = getattr(app.state, "health", None)  # ground/manager/health.py
        problems = await probe.problems() if probe is not None else []
        if problems:
            response.status_code = 503
        return {
            "ok": not problems,
            "status": "degraded" if problems else "ok",
            "problems": problems,
            "replica": replica() if (replica := getattr(app.state, "replica", None)) else None,
            "partition": part() if (part := getattr(app.state, "partition", None)) else None,
            "version": __version__,
            "dropped_messages": dropped() if dropped else {},
        }

    return app
