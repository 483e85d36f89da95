"""The Drone Manager's FastAPI application: routes, error shapes, OpenAPI docs at ``/docs``."""

from fastapi import FastAPI

from dronefleet import __version__
from dronefleet.ground.manager import (
    admin,
    control,
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
    )
    app.state.ctx = ctx
    errors.install(app)
    from dronefleet.ground.manager import separation
    from dronefleet.ground.photos import api as photos_api
    from dronefleet.ground.planner import api as planner_api
    from dronefleet.ground.planner import drone_api
    from dronefleet.ground.planner.files import api as files_api

    routers = (drones, control, telemetry, admin, stream, planner_api, files_api, photos_api)
    for module in (*routers, drone_api, maps, search, separation, signin, web):
        app.include_router(module.router)
    web.mount(app)
    app.add_middleware(Hardening)

    @app.get(
        "/api/v1/health",
        tags=["admin"],
        summary="Liveness of the ground services",
        response_model=Health,
    )
    async def health() -> dict[str, object]:
        dropped = getattr(app.state, "dropped", None)
        return {
            "ok": True,
            "version": __version__,
            "dropped_messages": dropped() if dropped else {},
        }

    return app
