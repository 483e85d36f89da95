"""One drone of a mission: pause it, resume it, abort it (issue 14: the per-drone panel).

The mission routes act on every drone of a mission; an operator watching one drone (a low
battery, a bird, a person walking under it) wants to act on that drone alone. These find the
drone's active leg and act on it only: a pause holds that drone (its mission is paused while it
is, as when someone else takes a drone over: ground/planner/progress.py), a resume flies it on,
and an abort sends it home. An aborted drone's steps not flown are not flown by anybody; the
mission goes on with its other drones and ends failed with that reason, or, when it was the last
drone flying, it is aborted whole (as ``POST /missions/{id}/abort``).
"""

from __future__ import annotations

from dronefleet.errors import Conflict
from dronefleet.ground.planner.models import Leg, MissionRecord, MissionState
from dronefleet.ground.planner.service import MissionPlanner
from dronefleet.messaging.missions import MissionAction


def _leg_of(planner: MissionPlanner, drone_id: str, what: str) -> tuple[MissionRecord, Leg]:
    for record in planner.missions.values():
        leg = None if record.terminal else record.leg_of(drone_id)
        if leg is not None and not leg.role.outgoing:
            return record, leg
    raise Conflict(f"drone {drone_id} flies no mission: nothing to {what}")


async def pause_drone(planner: MissionPlanner, drone_id: str) -> MissionRecord:
    """Ask ``drone_id`` to hold and keep the rest of its leg (it answers ``paused``)."""
    async with planner.lock:
        record, leg = _leg_of(planner, drone_id, "pause")
        if record.state is MissionState.PLANNED:
            raise Conflict(f"mission {record.mission_id} has not started")
        if leg.paused:
            raise Conflict(f"drone {drone_id} is paused already ({leg.paused})")
        await planner.ask_legs([leg], MissionAction.PAUSE)
        return record


async def resume_drone(planner: MissionPlanner, drone_id: str) -> MissionRecord:
    """Ask a paused ``drone_id`` to fly on with its leg (it answers ``resumed``)."""
    async with planner.lock:
        record, leg = _leg_of(planner, drone_id, "resume")
        if not leg.paused:
            raise Conflict(f"drone {drone_id} is not paused")
        await planner.ask_legs([leg], MissionAction.RESUME)
        return record


async def abort_drone(planner: MissionPlanner, drone_id: str) -> MissionRecord:
    """End ``drone_id``'s part of its mission and send it home (RTL, then land)."""
    async with planner.lock:
        record, leg = _leg_of(planner, drone_id, "abort")
        others = [
            lg for lg in record.active_legs() if lg.drone_id != drone_id and not lg.role.outgoing
        ]
        if others:
            await planner.send_home(record, leg)
            record.error = f"{drone_id} aborted by the operator: its steps left are not flown"
            if record.state is MissionState.PAUSED and not any(lg.paused for lg in others):
                record.state = (
                    MissionState.HANDED_OVER if record.handovers else MissionState.RUNNING
                )
            await planner.save(record)
            planner.emit("mission", **record.summary())
            return record
    # The last drone flying: the mission is aborted whole (and ends now).
    return await planner.stop_mission(record.mission_id, home=True)
