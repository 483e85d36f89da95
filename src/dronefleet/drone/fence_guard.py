"""The geofence kept to in flight (issue 14): a breach stops the mission and brings the drone home.

The ground checks a mission's fence before accepting it (ground/planner/geofence.py), but wind, a
pilot, a bad GPS or a mission sent by hand can still take a drone out. Every flight sample the
autopilot reports is checked against the running mission's fence (messaging/fence.py), as
ArduPilot's fence does: outside the inclusion polygon, inside an exclusion zone or above the
ceiling by more than :data:`MARGIN_M` (FENCE_MARGIN's role), the drone stops its mission with the
reason and returns home (ArduPilot's FENCE_ACTION 1, RTL). It acts once per mission.
"""

from __future__ import annotations

import asyncio
import logging
from typing import TYPE_CHECKING, Any

from dronefleet.geo.types import LLA
from dronefleet.messaging.fence import FenceShape, Geofence

if TYPE_CHECKING:
    from dronefleet.drone.mission_worker import MissionWorker

log = logging.getLogger(__name__)

#: Metres past the fence forgiven (position noise, a waypoint on the line); ArduPilot's
#: FENCE_MARGIN defaults to 2 m.
MARGIN_M = 2.0


class FenceGuard:
    """Fed every flight sample; a breach of the running mission's fence sends the drone home."""

    def __init__(self, worker: MissionWorker) -> None:
        self.worker = worker
        self.breaches = 0
        self._shape: tuple[Geofence, FenceShape] | None = None
        self._acted_for: str | None = None
        self._task: asyncio.Task[None] | None = None

    async def feed(self, fields: dict[str, Any], _vehicle_time_s: float) -> None:
        worker = self.worker
        fence, mission_id = worker.fence, worker.mission_id
        if fence is None or mission_id is None or not worker.running:
            return
        if mission_id == self._acted_for or not all(k in fields for k in ("lat", "lon", "alt_m")):
            return
        fc = worker.controller.fc
        if not fc.state().in_air:
            return
        here = LLA(fields["lat"], fields["lon"], fields["alt_m"])
        if self._shape is None or self._shape[0] is not fence:
            self._shape = (fence, FenceShape(fence, here))
        why = self._shape[1].breach(here, fc.home(), MARGIN_M)
        if why is not None:
            self._acted_for = mission_id
            self.breaches += 1
            self._task = asyncio.create_task(self._home(f"fence breach: {why}"), name="fence")

    async def _home(self, why: str) -> None:
        log.warning("drone %s: %s; returning home", self.worker.controller.drone_id, why)
        await self.worker.abandon(f"{why}: returning home")
        await self.worker.controller.navigation.return_to_launch()
