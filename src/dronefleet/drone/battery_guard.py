"""Battery fail-safe levels on the drone (issue 14): warn, then come home, then land.

The Fail-safe System's CRITICAL alarm (20 %, drone/failsafe.py) is a warning: the ground answers it
by sending a replacement and the drone home. When nobody does (no spare drone, replacement off,
the ground unreachable), the drone acts by itself, as ArduPilot's battery failsafe does with its
two levels (BATT_LOW_MAH/BATT_LOW_VOLT then BATT_FS_LOW_ACT, RTL by default here; BATT_CRT_* then
BATT_FS_CRT_ACT, Land): below ``rtl_pct`` it stops its mission and returns home; below
``land_pct`` it stops whatever it does and lands where it is. Each level acts once per flight; a
drone already coming home (its own RTL, or the ground's) or landing is left to it, except that
the land level still lands a drone that is only returning.

A landing decided for the battery is final (issue 26): until the drone is on the ground its
Navigation Processor flies nothing but a landing (``NavigationProcessor.must_land``), so a return
order queued for it (the ground's recovery leg, kept by the broker while the drone was away) or
sent later is refused with the reason (a mission fails at that step, a direct command answers
the refusal). Measured on SITL before: such an order took a drone at 0 % back into the air for
home.
"""

from __future__ import annotations

import asyncio
import logging
import math
from typing import TYPE_CHECKING, Any

from dronefleet.vehicle.base import FlightMode, VehicleState

if TYPE_CHECKING:
    from dronefleet.drone.mission_worker import MissionWorker

log = logging.getLogger(__name__)


class BatteryGuard:
    """Fed every flight sample (Drone Controller's sample listeners); acts at two levels."""

    def __init__(self, worker: MissionWorker, *, rtl_pct: float, land_pct: float) -> None:
        if not 0 <= land_pct <= rtl_pct <= 100:
            raise ValueError(f"battery levels: land {land_pct} % must be under RTL {rtl_pct} %")
        self.worker, self.rtl_pct, self.land_pct = worker, rtl_pct, land_pct
        self.acted: list[str] = []  # "rtl", "land": what it did this flight
        self._task: asyncio.Task[None] | None = None

    async def feed(self, fields: dict[str, Any], _vehicle_time_s: float) -> None:
        pct = fields.get("battery_pct")
        if not isinstance(pct, int | float) or not math.isfinite(pct):
            return
        state = self.worker.controller.fc.state()
        if not state.in_air:
            self.acted.clear()  # on the ground (a new battery, a new flight): armed again
            self.worker.controller.navigation.must_land = None
            return
        if self._task is not None and not self._task.done():
            return  # acting already
        if pct < self.land_pct and "land" not in self.acted and not state.landing:
            self._act("land", pct)
        elif pct < self.rtl_pct and not self.acted and not self._going_home(state):
            self._act("rtl", pct)

    def _going_home(self, state: VehicleState) -> bool:
        """Landing, or coming home: the autopilot's RTL, or ours (navigation.landing)."""
        homing = self.worker.controller.navigation.landing
        return state.landing or homing or state.mode in (FlightMode.RTL, FlightMode.LAND)

    def _act(self, level: str, pct: float) -> None:
        self.acted.append(level)
        self._task = asyncio.create_task(self._do(level, pct), name=f"battery-{level}")

    async def _do(self, level: str, pct: float) -> None:
        what = "landing here" if level == "land" else "returning home"
        why = f"battery at {pct:.1f} % (below {getattr(self, f'{level}_pct'):g} %): {what}"
        log.warning("drone %s: %s", self.worker.controller.drone_id, why)
        navigation = self.worker.controller.navigation
        if level == "land":
            navigation.must_land = f"the drone is landing for its battery ({why})"
        await self.worker.abandon(why)
        if level == "land":
            await navigation.land()
        else:
            await navigation.return_to_launch()
