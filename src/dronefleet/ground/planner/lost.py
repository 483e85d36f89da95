"""A lost drone's work is taken over (issue 13), carefully (issue 26).

The Drone Identifier declares a drone lost after three of its heartbeat intervals of silence in
the ground's awake time (ground/fleet.py). Being lost is the ground's view, not a fact about the
drone: a drone flies on through a lost link (drone/outbox.py), so nothing is done to it, or to its
work, on that view alone.

- :func:`confirm`: the work is taken over only after a further confirmation period (the drone's
  own lost-after time again, in the planner's awake time), if the drone is still lost then and the
  Drone Identifier, asked again, agrees.
- :func:`take_over`: the replacement is chosen, and the choice written, in one step under the
  planner's lock; it flies exactly the steps the lost drone had not reported (ground/planner/
  replacement.py), from the last place the drone was known to be. Nobody is sent home yet.
- :func:`commit_started`: once the replacement has started on those steps (it reported the last
  step of its way there), the takeover has happened: the lost drone is sent a recovery leg that
  brings it home (RTL), kept by the broker's persistent session, and sent again when it is back
  online (a restarted drone forgot it); its reports are asked for, so late ones are reconciled.
- :func:`cancel`: a drone heard again before that keeps its leg and flies on; the replacement is
  sent home and the takeover is recorded as called off (``takeovers_cancelled``).

With replacement off, its position unknown, or nobody able to take over, the mission is
``stalled`` with the reason (the lost drone's leg keeps it open; takeover is tried again every
:data:`RETRY_S` while nobody is free) and runs again when the drone is back: its reports, asked
for again, close the mission. A lost drone whose work is all done holds nothing open.
"""

from __future__ import annotations

import logging
from typing import Any

from dronefleet.ground.fleet import LOST_AFTER_INTERVALS, MIN_LOST_AFTER_S, sleep_awake
from dronefleet.ground.planner import replacement
from dronefleet.ground.planner.deconflict import Share
from dronefleet.ground.planner.ends import GO_HOME  # what a lost drone does when heard again
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
from dronefleet.ground.planner.traffic import keep_apart
from dronefleet.ground.planner.units import remaining
from dronefleet.messaging.commands import AlarmLevel
from dronefleet.messaging.common import Position

log = logging.getLogger(__name__)

#: Awake seconds between attempts to take a lost drone's work over while nobody is free.
RETRY_S = 10.0


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


def confirmation_s(heard: dict[str, Any] | None) -> float:
    """How long a drone must stay lost before its work is taken over: its own lost-after time
    (as the Drone Identifier judged it) once more."""
    heard = heard or {}
    lost_after = heard.get("lost_after_s")
    if isinstance(lost_after, int | float) and lost_after > 0:
        return float(lost_after)
    interval = heard.get("heartbeat_interval_s")
    interval = float(interval) if isinstance(interval, int | float) and interval > 0 else 5.0
    return max(MIN_LOST_AFTER_S, LOST_AFTER_INTERVALS * interval)


def work_left(record: MissionRecord, leg: Leg) -> list[int]:
    return remaining(record.work, leg.indices, set(record.done))


async def confirm(
    planner: PlannerOps, record: MissionRecord, leg: Leg, heard: dict[str, Any] | None, epoch: int
) -> None:
    """Take ``leg`` over if its drone, declared lost (the ``epoch``-th time), stays lost for
    :func:`confirmation_s` more; while nobody is free, try again every :data:`RETRY_S`."""
    drone_id = leg.drone_id
    wait = confirmation_s(heard)
    why = f"drone {drone_id} lost: no heartbeat for {2 * wait:.3g} s (confirmed)"
    try:
        while True:
            await sleep_awake(wait)
            if planner.lost_epochs.get(drone_id) != epoch or drone_id not in planner.lost:
                return  # heard again meanwhile: nothing is taken over
            if record.terminal or not leg.active or record.handed_over(leg):
                return
            still = await _still_lost(planner, drone_id)
            if still is False:
                # The Identifier hears it (its "online" did not reach us, or is on its way).
                await planner.back_online(drone_id)
                return
            if still is True and not await take_over(planner, record, leg, why, heard):
                return
            wait = RETRY_S
    finally:
        planner.confirming.discard(leg.leg_id)


async def _still_lost(planner: PlannerOps, drone_id: str) -> bool | None:
    """Whether the Drone Identifier still has ``drone_id`` lost (None: it did not answer)."""
    try:
        records = await planner.fleet.records()
    except Exception as exc:
        log.warning("planner: the Drone Identifier did not answer about %s: %s", drone_id, exc)
        return None
    found = next((d for d in records if d.get("drone_id") == drone_id), None)
    return found is None or found.get("status") == "lost"


async def take_over(
    planner: PlannerOps,
    record: MissionRecord,
    leg: Leg,
    why: str,
    heard: dict[str, Any] | None = None,
) -> bool:
    """Have ``leg``'s steps not flown taken over from its drone, which is lost or forgot its
    leg (``why``), or mark the mission stalled with why that cannot be done. The choice and its
    record are one step under the planner's lock, written before the leg goes out; the drone
    itself is told nothing until its replacement has started (:func:`commit_started`). True
    when it is worth trying again later (nobody was free)."""
    where = last_known(planner, record, leg, heard)
    if where is None or not record.options.replacement:
        how = "replacement is off" if where is not None else "its position is unknown"
        await stall(planner, record, f"{why}; {how}")
        return False
    position, vehicle_s = where
    async with planner.lock:
        if record.terminal or leg.role.outgoing or not leg.active or record.handed_over(leg):
            return False
        left = work_left(record, leg)
        if not left:  # nothing to take over: its leg holds the mission open no more
            log.info("mission %s: %s (its work is done)", record.mission_id, why)
            await planner.settle_locked(record)
            return False
        log.warning("mission %s: %s", record.mission_id, why)
        new_leg = await replacement.choose(planner, record, leg, (position.lat, position.lon), left)
        if isinstance(new_leg, str):
            if not record.terminal:
                record.state = MissionState.STALLED
                record.error = f"{why}; nobody can take over: {new_leg}"
                await planner.save(record)
                planner.emit("mission", **record.summary())
                log.warning("mission %s stalled: %s", record.mission_id, record.error)
            return True
        leg.state = LegState.REPLACED
        handover = Handover(
            kind=HandoverKind.ON_ALARM,
            from_drone=leg.drone_id,
            from_leg=leg.leg_id,
            reason=why,
            alarm_vehicle_s=vehicle_s,
            resume_position=LatLon(lat=position.lat, lon=position.lon),
            resume_index=left[0],
            remaining_steps=len(left),
            leave_vehicle_s=vehicle_s,
            to_drone=new_leg.drone_id,
            to_leg=new_leg.leg_id,
            committed=False,
            recovery=list(GO_HOME),
        )
        record.handovers.append(handover)
        record.state, record.error = MissionState.HANDED_OVER, None
        await planner.send_leg(record, new_leg)  # written (with the handover), then sent
    planner.emit("handover", mission_id=record.mission_id, **handover.model_dump(mode="json"))
    log.info(
        "mission %s: %s takes over from %s (called off if %s is heard before it starts)",
        record.mission_id,
        new_leg.drone_id,
        leg.drone_id,
        leg.drone_id,
    )
    return False


def started_on_work(leg: Leg) -> bool:
    """Whether a replacement leg's drone has started on the work handed to it: it reported the
    last step of its way there (or had no way to go)."""
    if leg.state is LegState.SENT:
        return False
    if not leg.prefix:
        return True
    last = len(leg.prefix) - 1
    return leg.state is LegState.COMPLETED or any(r.drone_step >= last for r in leg.reports)


async def commit_started(planner: PlannerOps, record: MissionRecord, leg: Leg) -> None:
    """(The planner's lock held, ``leg`` just reported.) A takeover whose replacement ``leg``
    has started on the work has happened: its lost drone is sent home."""
    for handover in record.handovers:
        if not handover.committed and handover.to_leg == leg.leg_id and started_on_work(leg):
            await _commit(planner, record, handover)


async def _commit(planner: PlannerOps, record: MissionRecord, handover: Handover) -> None:
    handover.committed = True
    going = Leg(
        leg_id=planner.next_leg_id(record),
        drone_id=handover.from_drone,
        role=LegRole.RECOVERY,
        prefix=list(handover.recovery or GO_HOME),
    )
    handover.recovery_leg = going.leg_id
    await planner.send_leg(record, going)  # written, then sent (kept for it by the broker)
    log.info(
        "mission %s: %s has started on %s's work; %s is sent home",
        record.mission_id,
        handover.to_drone,
        handover.from_drone,
        handover.from_drone,
    )


async def cancel(planner: PlannerOps, drone_id: str) -> None:
    """``drone_id`` is heard again: every takeover of its work whose replacement has not started
    on it yet is called off. The drone keeps its leg; the replacement is sent home. (A drone
    that raised CRITICAL meanwhile is not kept: its takeover happens.)"""
    for record in list(planner.missions.values()):
        if record.terminal:
            continue
        async with planner.lock:
            for handover in list(record.handovers):
                if handover.committed or handover.from_drone != drone_id:
                    continue
                await _call_off(planner, record, handover)


async def _call_off(planner: PlannerOps, record: MissionRecord, handover: Handover) -> None:
    old, new = record.leg(handover.from_leg), record.leg(handover.to_leg or "")
    critical = any(
        a.level is AlarmLevel.CRITICAL and a.mission_id == handover.from_leg for a in record.alarms
    )
    if old is None or critical:
        await _commit(planner, record, handover)
        return
    why = f"{handover.from_drone} heard again before {handover.to_drone} started on its work"
    handover.cancelled = why
    record.handovers.remove(handover)
    record.takeovers_cancelled.append(handover)
    old.state = (
        LegState.RUNNING if (old.started_vehicle_s is not None or old.reports) else (LegState.SENT)
    )
    if record.state in (MissionState.HANDED_OVER, MissionState.STALLED):
        record.state = MissionState.HANDED_OVER if record.handovers else MissionState.RUNNING
        record.error = None
    if new is not None and new.active:
        await planner.send_home(record, new)  # written, then sent
    await planner.save(record)
    planner.emit("mission", **record.summary())
    log.info("mission %s: takeover called off: %s", record.mission_id, why)


#: Awake seconds a returning drone's burst of reports is gathered before its replacement's leg
#: is cut to what neither has flown.
TRIM_AFTER_S = 1.0


def flew_unheard(planner: PlannerOps, record: MissionRecord, leg: Leg) -> None:
    """(The planner's lock held.) ``leg``, taken over by a replacement that has started, reports
    a step its drone flew while unheard (it flew on through its lost link): once its burst is in
    (:data:`TRIM_AFTER_S`), the replacement is given only what neither has flown
    (:func:`trim`)."""
    if leg.active or not leg.reports:
        return
    handover = next(
        (h for h in record.handovers if h.from_leg == leg.leg_id and h.committed and h.to_leg),
        None,
    )
    if handover is None or handover.to_leg in planner.trimming:
        return
    planner.trimming.add(handover.to_leg or "")
    planner.spawn(_trim_later(planner, record, handover), f"trim:{handover.to_leg}")


async def _trim_later(planner: PlannerOps, record: MissionRecord, handover: Handover) -> None:
    leg_id = handover.to_leg or ""
    try:
        await sleep_awake(TRIM_AFTER_S)
    finally:
        planner.trimming.discard(leg_id)
    async with planner.lock:
        if handover.to_leg == leg_id:
            await trim(planner, record, handover)


async def trim(planner: PlannerOps, record: MissionRecord, handover: Handover) -> None:
    """(The lock held.) Cut the replacement's leg of ``handover`` to the steps nobody has flown
    (issue 26: a drone taken over while unheard flew on, and came back; before, its replacement
    flew those steps again). Its drone is sent a leg with the rest of its work from where it
    is (kept clear of the traffic), or with only its way home; unchanged if that cannot be
    kept clear."""
    new = record.leg(handover.to_leg or "")
    if record.terminal or new is None or not new.active or not started_on_work(new):
        return
    mine = {r.index for r in new.reports if r.index is not None}
    taken = [i for i in new.indices if i not in mine and record.done.get(i, "") != new.drone_id]
    taken = [i for i in taken if i in record.done]
    if not taken:
        return
    left = remaining(record.work, new.indices, set(record.done))
    steps = [record.work[i] for i in left]
    try:
        fleet = await planner.fleet.drones()
        view = next((d for d in fleet if d.drone_id == new.drone_id), None)
        if view is None:
            return
        share = Share(
            new.drone_id, [], steps, list(new.suffix), view.position, view.home, view.airborne,
            view.flight,
        )  # fmt: skip
        (placed,) = await keep_apart(planner, fleet, [share])
    except Exception as exc:  # not kept clear, or not planned: it flies its leg as it is
        log.warning("mission %s: %s's leg not cut: %s", record.mission_id, new.drone_id, exc)
        return
    cut = Leg(
        leg_id=planner.next_leg_id(record),
        drone_id=new.drone_id,
        role=LegRole.REPLACEMENT,
        prefix=list(placed.prefix),
        indices=left,
        suffix=list(placed.end),
    )
    new.state = LegState.REPLACED
    handover.to_leg = cut.leg_id
    handover.remaining_steps = len(left)
    await planner.send_leg(record, cut)  # written, then sent: it stops the old leg first
    log.info(
        "mission %s: %s flew %d step(s) unheard that %s had: %s flies the %d left",
        record.mission_id, handover.from_drone, len(taken), new.leg_id, new.drone_id, len(left),
    )  # fmt: skip


def stalled_by_others(planner: PlannerOps, record: MissionRecord, drone_id: str) -> bool:
    """Whether another drone than ``drone_id``, still lost with work nobody took over, keeps
    ``record`` stalled (issue 26: a drone back from a short outage ran again a mission stalled
    on a drone killed for good)."""
    return any(
        leg.drone_id != drone_id
        and leg.drone_id in planner.lost
        and not leg.role.outgoing
        and not record.handed_over(leg)
        and work_left(record, leg)
        for leg in record.active_legs()
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
        record.state = MissionState.HANDED_OVER if record.handovers else MissionState.RUNNING
        record.error = None
        await planner.save(record)
    planner.emit("mission", **record.summary())
    log.info("mission %s runs again: %s", record.mission_id, why)
