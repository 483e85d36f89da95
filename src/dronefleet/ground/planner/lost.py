"""A lost drone's work is taken over (issue 13), as a CRITICAL alarm's would be.

The Drone Identifier declares a drone lost after three heartbeat intervals without it
(ground/identifier.py). Its active legs are then replaced from the last place it was known to be
(its last telemetry, else its last heartbeat): the replacement flies exactly the steps the lost
drone did not report done (ground/planner/replacement.py). The lost drone is sent a recovery leg
that brings it home (RTL), kept by the broker's persistent session; when it comes back online the
leg is sent again (a restarted drone forgot it) and its reports are asked for, so late reports are
reconciled: a step it did after all is recorded, none is flown twice without being recorded.
With replacement off, or nobody able to take over, the mission is ``stalled`` with the reason
(the lost drone's leg keeps it open) and runs again when the drone is back: a drone flies on
through a lost link (drone/outbox.py), and its reports, asked for again, close the mission.
"""

from __future__ import annotations

import logging
from typing import Any

from dronefleet.ground.planner import replacement
from dronefleet.ground.planner.ends import GO_HOME  # what a lost drone does when heard again
from dronefleet.ground.planner.models import Leg, MissionRecord, MissionState
from dronefleet.ground.planner.ops import PlannerOps
from dronefleet.messaging.commands import AlarmLevel
from dronefleet.messaging.common import Position
from dronefleet.messaging.status import Alarm

log = logging.getLogger(__name__)


def last_known(
    planner: PlannerOps, record: MissionRecord, leg: Leg, heard: dict[str, Any] | None
) -> tuple[Position, float] | None:
    """Where the drone was last known to be, and its vehicle time then: its last telemetry, its
    last heartbeat (``heard``: the drone as the Drone Identifier shows it), its last report."""
    fields = planner.latest.get(leg.drone_id)
    if fields is not None:
        return (
            Position(lat=fields["lat"], lon=fields["lon"], alt_m=fields.get("alt_m", 0.0)),
            float(fields.get("vehicle_time_s") or 0.0),
        )
    if heard is not None and isinstance(heard.get("position"), dict):
        return Position.model_validate(heard["position"]), float(heard.get("vehicle_time_s") or 0)
    report = next((r for r in reversed(leg.reports) if r.position), None)
    if report is not None and report.position is not None:
        return Position.model_validate(report.position), report.vehicle_time_s or 0.0
    return None


async def take_over(
    planner: PlannerOps,
    record: MissionRecord,
    leg: Leg,
    why: str,
    heard: dict[str, Any] | None = None,
) -> None:
    """Replace ``leg``'s drone, which is lost or forgot its leg (``why``), or mark the mission
    stalled with why that cannot be done."""
    where = last_known(planner, record, leg, heard)
    if where is None or not record.options.replacement:
        how = "replacement is off" if where is not None else "its position is unknown"
        await stall(planner, record, f"{why}; {how}")
        return
    position, vehicle_s = where
    alarm = Alarm(
        drone_id=leg.drone_id,
        level=AlarmLevel.CRITICAL,
        message=why,
        position=position,
        mission_id=leg.leg_id,
        vehicle_time_s=vehicle_s,
    )
    log.warning("mission %s: %s", record.mission_id, why)
    await replacement.replace(
        planner, record, leg, alarm, recovery=GO_HOME, give_up=MissionState.STALLED
    )


async def stall(planner: PlannerOps, record: MissionRecord, why: str) -> None:
    async with planner.lock:
        if record.terminal:
            return
        record.state, record.error = MissionState.STALLED, why
        await planner.save(record)
    planner.emit("mission", **record.summary())
    log.warning("mission %s stalled: %s", record.mission_id, why)


async def unstall(planner: PlannerOps, record: MissionRecord, why: str) -> None:
    """A stalled mission runs again (its lost drone is back); ``why`` is logged."""
    async with planner.lock:
        if record.state is not MissionState.STALLED:
            return
        record.state, record.error = MissionState.RUNNING, None
        await planner.save(record)
    planner.emit("mission", **record.summary())
    log.info("mission %s runs again: %s", record.mission_id, why)
