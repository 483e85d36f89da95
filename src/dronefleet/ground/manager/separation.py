"""``GET /api/v1/separation``: what the live separation monitor has seen (issue 14).

The counts of encounters (a breach predicted a few seconds ahead: WARNING; an actual one:
CRITICAL), the smallest separations seen between drones in the air, and the pairs in an
encounter now (ground/separation_monitor.py). The alarms themselves come over the live stream.
"""

from __future__ import annotations

from fastapi import APIRouter, Request

from dronefleet.errors import Unavailable
from dronefleet.ground.manager.context import Viewer
from dronefleet.ground.manager.errors import answers
from dronefleet.ground.separation_monitor import SeparationMonitor, SeparationStatus

router = APIRouter(prefix="/api/v1", tags=["safety"], responses=answers(401, 403, 503))


def monitor_of(request: Request) -> SeparationMonitor:
    monitor = getattr(request.app.state, "separation", None)
    if monitor is None:
        raise Unavailable("the separation monitor is not running")
    return monitor


@router.get("/separation", summary="Separation between drones: encounters and closest approach")
async def separation(request: Request, who: Viewer) -> SeparationStatus:
    return monitor_of(request).status()
