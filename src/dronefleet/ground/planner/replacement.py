"""Self-replacement (seed 3.1.5, 5.3): a drone that raises CRITICAL is replaced in flight.

The replacement is the idle, online drone with enough battery for the rest, nearest to where it
must go first (the failing drone's position). The failing drone goes home (or to the nearest
rally point) when the mission ends with RTL, else it lands where it is as the seed's did; the
replacement arms, takes off, flies to the failing drone's position and then flies exactly the
steps not yet flown: every waypoint unit not wholly done, none that is (see :mod:`.units`).

Exactly once (issue 26). Each step of a handover is taken under the planner's lock together with
the check that it is still to be taken, and written before any command goes out:

- :func:`decide`, as the planner records the alarm (the alarm is acknowledged to the broker only
  once both are written): the leg ends, a :class:`Handover` with nobody chosen yet is written,
  and the failing drone is sent its recovery. The same alarm delivered again is a no-op (the
  planner knows it), and so is any alarm for a leg already handed over.
- :func:`assign`, once the failing drone has accepted its recovery leg (every report of the leg
  it flew is in by then: a drone reports in order, and a new leg stops the old one first), or
  :data:`ASSIGN_WAIT_S` after the decision if it does not answer: the steps it did not report
  are given to the chosen drone, unless someone has them already (then nothing happens).
- :func:`resume`, at a ground's start, before it reads any live report or alarm: a handover
  decided and not yet assigned is assigned (at once if its recovery leg was accepted, else its
  recovery leg is sent again, in case it never left, and it is assigned as above).
"""

from __future__ import annotations

import asyncio
import logging
from typing import Any

from dronefleet.ground.planner.deconflict import Share
from dronefleet.ground.planner.ends import GO_HOME, end_steps
from dronefleet.ground.planner.estimate import can_finish, drone_model, estimate, fleet_draws
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
from dronefleet.ground.planner.traffic import keep_apart, orphan_of
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
    wind_mps: float | None = None,
    wind_from_deg: float = 0.0,
) -> tuple[DroneView, list[dict[str, Any]]] | tuple[None, str]:
    """The nearest candidate that can finish, each estimated as its own vehicle flies
    (estimate.drone_model) in the mission's wind; or (None, reason). CPU work (an estimate per
    candidate): callers run it in the planning worker (ground/planner/worker.py)."""
    from dronefleet.geo.types import LLA

    target = LLA(near[0], near[1])
    draws = fleet_draws([d.flight for d in fleet])
    reasons = []
    for drone in candidates(fleet, target, exclude=exclude):
        prefix = preparation(drone, altitude_m, strategy=strategy, go_to=near)
        est = estimate(
            prefix + work_steps,
            start=drone.position,
            home=drone.home,
            airborne=drone.airborne,
            battery_pct=drone.battery_pct,
            model=drone_model(
                drone.flight, draws, reported_wind=drone.wind, wind_mps=wind_mps,
                wind_from_deg=wind_from_deg,
            ),
        )  # fmt: skip
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


#: Seconds the replacement waits for the failing drone to accept its recovery leg.
ASSIGN_WAIT_S = 2.0
#: Seconds before a replacement is looked for again after the planning itself failed.
RETRY_S = 10.0


class Transient(str):
    """Why nobody was chosen, when it was the planning that failed (a worker over its budget on
    a loaded host, a worker lost), not the fleet: worth trying again."""


def decide(
    planner: PlannerOps,
    record: MissionRecord,
    leg: Leg,
    alarm: Alarm,
    *,
    recovery: tuple[dict[str, Any], ...] | None = None,
) -> tuple[Handover, Leg] | None:
    """Decide ``leg``'s handover after its drone's CRITICAL ``alarm``: end the leg, write the
    handover (nobody chosen yet) and the failing drone's recovery leg (by default
    :func:`recovery_of` the mission) into ``record``. The caller holds the planner's lock and
    saves and sends the recovery leg. None when there is nothing to decide: the leg is already
    handed over, ended, or a drone's way out."""
    if record.terminal or leg.role.outgoing or not leg.active or record.handed_over(leg):
        return None
    leg.state = LegState.REPLACED
    left = remaining(record.work, leg.indices, set(record.done))
    near = (alarm.position.lat, alarm.position.lon)
    going = Leg(
        leg_id=planner.next_leg_id(record),
        drone_id=leg.drone_id,
        role=LegRole.RECOVERY,
        prefix=list(recovery_of(record) if recovery is None else recovery),
    )
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
        recovery_leg=going.leg_id,
    )
    record.handovers.append(handover)
    record.legs.append(going)
    return handover, going


def waiting(handover: Handover) -> bool:
    """Whether ``handover`` is decided and nobody has been given its steps yet."""
    return (
        handover.kind is HandoverKind.ON_ALARM
        and handover.to_leg is None
        and handover.error is None
        and handover.committed
    )


def ready_on(record: MissionRecord, leg: Leg) -> Handover | None:
    """The waiting handover whose failing drone has just accepted ``leg``, its recovery leg."""
    if leg.role is not LegRole.RECOVERY or leg.state is LegState.SENT:
        return None
    return next((h for h in record.handovers if h.recovery_leg == leg.leg_id and waiting(h)), None)


async def assign_after(
    planner: PlannerOps, record: MissionRecord, handover: Handover, wait_s: float = ASSIGN_WAIT_S
) -> None:
    """:func:`assign`, ``wait_s`` from now (if the failing drone has not answered by then)."""
    await asyncio.sleep(wait_s)
    await assign(planner, record, handover)


async def assign(planner: PlannerOps, record: MissionRecord, handover: Handover) -> None:
    """Give ``handover``'s steps to a drone, if nobody has them yet."""
    async with planner.lock:
        await assign_locked(planner, record, handover)


async def assign_locked(planner: PlannerOps, record: MissionRecord, handover: Handover) -> None:
    """:func:`assign` with the planner's lock held: the check that the handover is still
    waiting and the assignment are one step."""
    if record.terminal or not waiting(handover) or handover not in record.handovers:
        return
    leg = record.leg(handover.from_leg)
    if leg is None:
        return
    # The steps not flown as they are known now: the failing drone's reports up to its stop.
    left = remaining(record.work, leg.indices, set(record.done))
    handover.resume_index, handover.remaining_steps = (left[0] if left else None), len(left)
    if not left:
        await planner.save(record)  # it flew everything: nothing to hand over
        return
    log.info("mission %s: choosing who takes over %s", record.mission_id, leg.leg_id)
    await _hand_over(planner, record, leg, handover, left)


async def resume(planner: PlannerOps, record: MissionRecord) -> None:
    """Finish the handovers a ground restart interrupted: decided and written (the old drone
    was sent its recovery) but nobody chosen yet. The caller holds the planner's lock (the
    planner reads no live report or alarm before this is done)."""
    for handover in list(record.handovers):
        if record.terminal or not waiting(handover) or record.leg(handover.from_leg) is None:
            continue
        going = record.leg(handover.recovery_leg) if handover.recovery_leg else None
        log.info("mission %s: resuming the handover of %s", record.mission_id, handover.from_leg)
        if going is None or going.state is not LegState.SENT:
            await assign_locked(planner, record, handover)  # its reports are all in
        else:
            # Never heard accepted: the ground may have died after writing it and before it
            # reached the broker (the alarm, delivered again, is then known and answers
            # nothing). Sent again, so the drone stops flying its leg before its steps not
            # flown are given to another (issue 26: both flew them). A drone that had it
            # already starts its way out again.
            await planner.send_leg(record, going)
            planner.spawn(assign_after(planner, record, handover), f"assign:{going.leg_id}")


async def choose(
    planner: PlannerOps,
    record: MissionRecord,
    leg: Leg,
    near: tuple[float, float],
    left: list[int],
) -> Leg | str:
    """The leg that would give ``left`` (``leg``'s steps not flown) to the nearest drone able to
    fly them from ``near``, kept clear of the traffic; or why there is none. Changes nothing."""
    try:
        fleet = await planner.fleet.drones()
        why = "no drone is known to the Drone Identifier"
    except Exception as exc:
        fleet, why = [], f"the Drone Identifier did not answer: {exc}"
    if not fleet:
        return why
    work = [record.work[i] for i in left]
    end = end_steps(record.options.end_action, work)  # its battery check counts the way home
    trigger = camera_state(record, leg)  # restored on arrival, for fly-through surveys
    altitude = mission_altitude(record.work)
    try:
        chosen, prefix_or_reason = await planner.worker.run(
            pick,
            planner.reserve_pct,
            fleet,
            near,
            work + end,
            altitude,
            planner.busy_drones() | {leg.drone_id},
            record.options.strategy,
            record.options.wind_mps,
            record.options.wind_from_deg,
        )
    except Exception as exc:  # over its budget on a loaded host, a worker lost: nobody this time
        log.warning("mission %s: choosing a replacement failed: %r", record.mission_id, exc)
        return Transient(f"choosing a replacement failed: {exc}")
    if chosen is None:
        return str(prefix_or_reason)
    assert not isinstance(prefix_or_reason, str)  # a chosen drone comes with its preparation
    planned = Share(
        chosen.drone_id, prefix_or_reason, work, end, chosen.position, chosen.home,
        chosen.airborne, chosen.flight,
    )  # fmt: skip
    # The drone it replaces, if its leg still runs (a lost drone's takeover is decided before
    # anything is done to it), is traffic as it will be, not as flying that leg on.
    also = [s for s in [replaced_as(planner, fleet, leg)] if s is not None] if leg.active else []
    try:  # kept clear of the drone it replaces (coming down or lost) and of everyone else
        (placed,) = await keep_apart(planner, fleet, [planned], also=also, alter_work=True)
    except SeparationConflict as exc:
        return str(exc)
    except Exception as exc:
        log.warning("mission %s: keeping a replacement clear failed: %r", record.mission_id, exc)
        return Transient(f"keeping the replacement clear failed: {exc}")
    prefix = list(placed.prefix)
    if trigger:
        prefix.append({"command": Command.CAMERA_TRIGGER.value, "value": trigger})
    flown = placed.work or work  # near a lost drone, some steps on another layer
    return Leg(
        leg_id=planner.next_leg_id(record),
        drone_id=chosen.drone_id,
        role=LegRole.REPLACEMENT,
        prefix=prefix,
        indices=left,
        suffix=placed.end,
        altered={i: s for i, s, w in zip(left, flown, work, strict=True) if s != w},
    )


def replaced_as(planner: PlannerOps, fleet: list[DroneView], leg: Leg) -> Share | None:
    """The drone of ``leg``, about to be replaced, as traffic (never as flying that leg on): lost
    in the air, an orphan (its last place kept clear: ground/planner/orphans.py); heard and in
    the air, going home (it is sent there once its replacement has started); on the ground,
    staying there."""
    view = next((d for d in fleet if d.drone_id == leg.drone_id), None)
    if view is None:
        return None
    if not view.airborne:  # staying where it is (named, so that its leg is not traffic)
        return Share(view.drone_id, [], [], [], view.position, view.home, False, view.flight)
    if not view.online:
        return orphan_of(view, planner.latest.get(view.drone_id))
    home = [dict(step) for step in GO_HOME]
    return Share(
        view.drone_id, [], [], home, view.position, view.home, True, view.flight
    )  # fmt: skip


async def _hand_over(
    planner: PlannerOps,
    record: MissionRecord,
    leg: Leg,
    handover: Handover,
    left: list[int],
) -> None:
    """Choose who flies ``left`` and send it (the planner's lock held); with nobody able to,
    the mission fails with the reason."""
    assert handover.resume_position is not None  # an on-alarm handover says where to resume
    near = (handover.resume_position.lat, handover.resume_position.lon)
    new_leg = await choose(planner, record, leg, near, left)
    if isinstance(new_leg, Transient):
        log.warning("mission %s: %s; trying again in %g s", record.mission_id, new_leg, RETRY_S)
        planner.spawn(assign_after(planner, record, handover, RETRY_S), f"retry:{leg.leg_id}")
        return
    if isinstance(new_leg, str):
        handover.error = new_leg
        await planner.finish(record, MissionState.FAILED, f"replacement failed: {new_leg}")
        log.warning("mission %s: %s", record.mission_id, record.error)
        return
    handover.to_drone, handover.to_leg = new_leg.drone_id, new_leg.leg_id
    record.state = MissionState.HANDED_OVER
    await planner.send_leg(record, new_leg)  # written, then sent
    planner.emit("handover", mission_id=record.mission_id, **handover.model_dump(mode="json"))
    log.info("mission %s: %s replaces %s", record.mission_id, new_leg.drone_id, leg.drone_id)
