"""Self-replacement (seed 3.1.5, 5.3): a drone that raises CRITICAL is replaced in flight.

The replacement is the idle, online drone with enough battery for the rest, nearest to where it
must go first (the failing drone's position). The failing drone goes home (or to the nearest
rally point) when the mission ends with RTL, else it lands where it is as the seed's did; the
replacement arms, takes off, flies to the failing drone's position and then flies exactly the
steps not yet flown: every waypoint unit not wholly done, none that is (see :mod:`.units`).
"""

from __future__ import annotations

import logging
from typing import Any

from dronefleet.ground.planner.deconflict import Share
from dronefleet.ground.planner.ends import GO_HOME, end_steps
from dronefleet.ground.planner.estimate import can_finish, estimate
from dronefleet.ground.planner.fleet_view import DroneView, candidates
from dronefleet.ground.planner.legs import mission_altitude, preparation
from dronefleet.ground.planner.models import (
    Handover,
    HandoverKind,
    LatLon,
    Leg,
    LegState,
    MissionRecord,
    MissionState,
)
from dronefleet.ground.planner.ops import PlannerOps
from dronefleet.ground.planner.options import LegRole
from dronefleet.ground.planner.separation import SeparationConflict
from dronefleet.ground.planner.traffic import keep_apart
from dronefleet.ground.planner.units import remaining
from dronefleet.messaging.commands import Command
from dronefleet.messaging.status import Alarm

log = logging.getLogger(__name__)


def camera_state(record: MissionRecord, leg: Leg) -> float:
    """The camera-trigger distance in force when the leg stopped (0: off)."""
    distance = 0.0
    for i in leg.indices:
        if i in record.done and record.work[i].get("command") == Command.CAMERA_TRIGGER:
            distance = float(record.work[i].get("value") or 0.0)
    return distance


def pick(
    reserve_pct: float,
    fleet: list[DroneView],
    near: tuple[float, float],
    work_steps: list[dict[str, Any]],
    altitude_m: float,
    exclude: set[str],
    strategy: str,
) -> tuple[DroneView, list[dict[str, Any]]] | tuple[None, str]:
    """The nearest candidate that can finish; or (None, reason). CPU work (an estimate per
    candidate): callers run it in the planning worker (ground/planner/worker.py)."""
    from dronefleet.geo.types import LLA

    target = LLA(near[0], near[1])
    reasons = []
    for drone in candidates(fleet, target, exclude=exclude):
        prefix = preparation(drone, altitude_m, strategy=strategy, go_to=near)
        est = estimate(
            prefix + work_steps,
            start=drone.position,
            home=drone.home,
            airborne=drone.airborne,
            battery_pct=drone.battery_pct,
        )
        ok, why = can_finish(est, reserve_pct=reserve_pct)
        if ok:
            return drone, prefix
        reasons.append(f"{drone.drone_id}: {why}")
    return None, "no idle drone can take over" + (f" ({'; '.join(reasons)})" if reasons else "")


#: What a replaced drone does in a mission that does not end with RTL: the seed's controlled
#: descent where it is (the experiments keep it, as the seed's end).
LAND_HERE = ({"command": Command.LAND.value}, {"command": Command.WAIT_FOR_FLIGHT.value})


def recovery_of(record: MissionRecord) -> tuple[dict[str, Any], ...]:
    """How a replaced drone leaves: home, or the nearest rally point on the way (``GO_HOME``),
    when the mission ends with RTL (the default), rather than landing in the field (issue 14:
    a departing drone landed 140 m from home)."""
    return GO_HOME if record.options.end_action == "rtl" else LAND_HERE


async def replace(
    planner: PlannerOps,
    record: MissionRecord,
    leg: Leg,
    alarm: Alarm,
    *,
    recovery: tuple[dict[str, Any], ...] | None = None,
    give_up: MissionState = MissionState.FAILED,
) -> None:
    """Replace the drone flying ``leg`` after its CRITICAL ``alarm`` (or its loss: ground/
    planner/lost.py). The drone flies ``recovery`` (by default :func:`recovery_of` the mission);
    with nobody to take over, the mission turns ``give_up`` with the reason."""
    if recovery is None:
        recovery = recovery_of(record)
    async with planner.lock:
        if leg.role.outgoing:
            return  # already on its way out: its replacement is planned
        if not leg.active or record.handed_over(leg):
            return
        leg.state = LegState.REPLACED
        left = remaining(record.work, leg.indices, set(record.done))
        near = (alarm.position.lat, alarm.position.lon)
        handover = Handover(
            kind=HandoverKind.ON_ALARM,
            from_drone=leg.drone_id,
            from_leg=leg.leg_id,
            reason=alarm.message or "CRITICAL alarm",
            alarm_vehicle_s=alarm.vehicle_time_s,
            resume_position=LatLon(lat=near[0], lon=near[1]),
            resume_index=left[0] if left else None,
            remaining_steps=len(left),
            leave_vehicle_s=alarm.vehicle_time_s,
        )
        record.handovers.append(handover)
        # The failing drone stops and comes down (where it is, unless told otherwise).
        recovery_leg = Leg(
            leg_id=planner.next_leg_id(record),
            drone_id=leg.drone_id,
            role=LegRole.RECOVERY,
            prefix=list(recovery),
        )
        await planner.send_leg(record, recovery_leg)
        if left:
            await _hand_over(planner, record, leg, handover, left, give_up)


async def resume(planner: PlannerOps, record: MissionRecord) -> None:
    """Finish the handovers a ground restart interrupted: decided and written (the old drone
    was sent its recovery) but nobody chosen yet."""
    for handover in record.handovers:
        leg = record.leg(handover.from_leg)
        unfinished = handover.to_leg is None and handover.error is None
        if leg is None or not unfinished or handover.kind is not HandoverKind.ON_ALARM:
            continue
        async with planner.lock:
            left = remaining(record.work, leg.indices, set(record.done))
            if left and not record.terminal:
                log.info("mission %s: resuming the handover of %s", record.mission_id, leg.leg_id)
                await _hand_over(planner, record, leg, handover, left, MissionState.STALLED)


async def _hand_over(
    planner: PlannerOps,
    record: MissionRecord,
    leg: Leg,
    handover: Handover,
    left: list[int],
    give_up: MissionState,
) -> None:
    """Choose who flies ``left`` and send it (the planner's lock held)."""
    assert handover.resume_position is not None  # an on-alarm handover says where to resume
    near = (handover.resume_position.lat, handover.resume_position.lon)
    try:
        fleet = await planner.fleet.drones()
        why = "no drone is known to the Drone Identifier"
    except Exception as exc:
        fleet, why = [], f"the Drone Identifier did not answer: {exc}"
    work = [record.work[i] for i in left]
    end = end_steps(record.options.end_action, work)  # its battery check counts the way home
    trigger = camera_state(record, leg)  # restored on arrival, for fly-through surveys
    altitude = mission_altitude(record.work)
    chosen, prefix_or_reason = (
        (None, why)
        if not fleet
        else await planner.worker.run(
            pick,
            planner.reserve_pct,
            fleet,
            near,
            work + end,
            altitude,
            planner.busy_drones() | {leg.drone_id},
            record.options.strategy,
        )
    )
    if chosen is not None:
        assert not isinstance(prefix_or_reason, str)  # a chosen drone comes with its preparation
        planned = Share(
            chosen.drone_id, prefix_or_reason, work, end, chosen.position, chosen.home,
            chosen.airborne, chosen.flight,
        )  # fmt: skip
        try:  # kept clear of the drone it replaces (coming down) and of everyone else
            (placed,) = await keep_apart(planner, fleet, [planned])
            prefix_or_reason, end = placed.prefix, placed.end
        except SeparationConflict as exc:
            chosen, prefix_or_reason = None, str(exc)
    if chosen is None:
        handover.error = str(prefix_or_reason)
        record.state = give_up
        record.error = f"replacement failed: {prefix_or_reason}"
        await planner.save(record)
        planner.emit("mission", **record.summary())
        log.warning("mission %s: %s", record.mission_id, record.error)
        return
    assert not isinstance(prefix_or_reason, str)  # a chosen drone comes with its preparation
    prefix = prefix_or_reason
    if trigger:
        prefix = [*prefix, {"command": Command.CAMERA_TRIGGER.value, "value": trigger}]
    new_leg = Leg(
        leg_id=planner.next_leg_id(record),
        drone_id=chosen.drone_id,
        role=LegRole.REPLACEMENT,
        prefix=prefix,
        indices=left,
        suffix=end,
    )
    handover.to_drone, handover.to_leg = chosen.drone_id, new_leg.leg_id
    record.state = MissionState.HANDED_OVER
    await planner.send_leg(record, new_leg)
    planner.emit("handover", mission_id=record.mission_id, **handover.model_dump(mode="json"))
    log.info("mission %s: %s replaces %s", record.mission_id, chosen.drone_id, leg.drone_id)
