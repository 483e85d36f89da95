"""A whole mission: stop it, abort it (its drones sent home), pause it, resume it (REST:
``/api/v1/missions/{id}/...``); ground/planner/drone_ops.py does the same for one drone.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from dronefleet.errors import Conflict
from dronefleet.ground.planner.models import MissionRecord, MissionState
from dronefleet.messaging.missions import MissionAction

if TYPE_CHECKING:
    from dronefleet.ground.planner.service import MissionPlanner


async def stop_mission(
    planner: MissionPlanner, mission_id: str, *, home: bool = False
) -> MissionRecord:
    """Stop a mission: its drones hold where they are, or (``home``: an abort) each is sent
    a leg that replaces what it flies with a return home (RTL)."""
    async with planner.lock:
        record = planner.get(mission_id)
        if record.terminal:
            return record
        for leg in record.active_legs():
            if home:
                await planner.send_home(record, leg)
            else:
                await planner.stop_leg(leg)
        why = "aborted on request: its drones were sent home" if home else "stopped on request"
        await planner.finish(record, MissionState.STOPPED, why)
        return record


async def abort_all(planner: MissionPlanner) -> list[MissionRecord]:
    """Abort every unfinished mission (its drones sent home); the missions aborted."""
    unfinished = [r.mission_id for r in list(planner.missions.values()) if not r.terminal]
    return [await stop_mission(planner, mission_id, home=True) for mission_id in unfinished]


async def pause_mission(planner: MissionPlanner, mission_id: str) -> MissionRecord:
    """Ask each drone of a running mission to hold and keep its steps left (each answers
    ``paused``; the mission is then paused until resumed)."""
    async with planner.lock:
        record = planner.get(mission_id)
        flying = [leg for leg in record.active_legs() if not leg.paused]
        if record.terminal or record.state is MissionState.PLANNED or not flying:
            raise Conflict(f"mission {mission_id} is {record.state.value}: nothing to pause")
        await planner.ask_legs(flying, MissionAction.PAUSE)
        return record


async def resume_mission(planner: MissionPlanner, mission_id: str) -> MissionRecord:
    """Ask each paused drone of a mission (taken over, or paused on request) to fly on with
    its leg (each answers ``resumed``, or ``paused`` again with why not: on the ground)."""
    async with planner.lock:
        record = planner.get(mission_id)
        paused = [leg for leg in record.active_legs() if leg.paused]
        if record.state is not MissionState.PAUSED or not paused:
            raise Conflict(f"mission {mission_id} is {record.state.value}, not paused")
        await planner.ask_legs(paused, MissionAction.RESUME)
        return record
