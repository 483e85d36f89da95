"""What replacement, early replacement and collaboration may do with the Mission Planner.

They used to take ``planner: Any`` and reach into its private lock and bookkeeping (issue 15).
This protocol is the whole of what they need: the fleet, the planning worker, the planner's
figures, its mission lock, and the operations that change a mission (send or stop a leg, send a
drone home, save, finish or settle a mission, tell listeners, run a task).
:class:`~dronefleet.ground.planner.service.MissionPlanner` satisfies it.
"""

from __future__ import annotations

import asyncio
from collections.abc import Mapping
from typing import Any, Protocol

from dronefleet.ground.planner.fleet_view import FleetView
from dronefleet.ground.planner.models import Leg, LegState, MissionRecord, MissionState
from dronefleet.ground.planner.start_delay import StartDelays
from dronefleet.ground.planner.worker import PlanningWorker


class PlannerOps(Protocol):
    @property
    def latest(self) -> Mapping[str, dict[str, Any]]:  # drone id -> its latest telemetry fields
        ...

    fleet: FleetView
    worker: PlanningWorker
    reserve_pct: float
    max_altitude_m: float
    missions: dict[str, MissionRecord]  # every mission it knows (their legs are the traffic)
    lost: set[str]  # drones the Drone Identifier last declared lost
    lost_epochs: dict[str, int]  # drone id -> times it was declared lost or back
    confirming: set[str]  # legs whose drone's loss is being confirmed (ground/planner/lost.py)
    trimming: set[str]  # replacement legs about to be cut to what nobody flew (lost.py)
    check_delays: dict[str, float]  # leg id -> its early checks' longest delay (early.py)
    start_delays: StartDelays  # legs' send-to-start delays (start_delay.py)
    check_again: set[str]  # legs that reported a step while their early check ran (early.py)

    @property
    def lock(self) -> asyncio.Lock:
        """Held while a mission's legs change."""
        ...

    @property
    def checking(self) -> set[str]:
        """Legs whose early-replacement check is running."""
        ...

    def busy_drones(self) -> set[str]: ...

    def next_leg_id(self, record: MissionRecord) -> str: ...

    async def send_leg(self, record: MissionRecord, leg: Leg) -> None: ...

    async def stop_leg(self, leg: Leg, *, state: LegState = ...) -> None: ...

    async def send_home(self, record: MissionRecord, leg: Leg) -> None: ...

    async def save(self, record: MissionRecord) -> None: ...

    async def finish(
        self, record: MissionRecord, state: MissionState, error: str | None = None
    ) -> None: ...

    async def settle_locked(self, record: MissionRecord) -> None: ...

    async def back_online(self, drone_id: str) -> None: ...

    def emit(self, event: str, /, **data: Any) -> None: ...

    def spawn(self, coro: Any, name: str) -> None: ...
