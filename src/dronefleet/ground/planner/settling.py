"""When a mission ends, and how its end is written: a mission ends once every leg has ended (or
its drone is lost with nothing of its own left to fly), not while reports of a leg are being
asked for again; its state follows from its legs', and its end is written with its log.
"""

from __future__ import annotations

import asyncio
import logging
import time
from typing import TYPE_CHECKING

from dronefleet.clock import timestamp_s
from dronefleet.ground.planner import reconcile
from dronefleet.ground.planner.mission_log import build_log
from dronefleet.ground.planner.models import Leg, LegState, MissionRecord, MissionState
from dronefleet.ground.planner.units import remaining

if TYPE_CHECKING:
    from dronefleet.ground.planner.service import MissionPlanner

log = logging.getLogger(__name__)


async def settle_locked(planner: MissionPlanner, record: MissionRecord) -> None:
    """(The lock held.) End the mission if every leg has ended (or its drone is lost with
    nothing of its own left to fly, or its work taken over): its state follows from its
    legs'. Not while reports of a leg are missing and being asked for again from a drone
    that is heard (:func:`refilling`): the mission ends once they are in."""
    if record.terminal or any(holds_open(planner, record, lg) for lg in record.active_legs()):
        return
    if refilling(planner, record):
        return
    left = remaining(record.work, record.required_indices(), set(record.done))
    if not left:
        await finish(planner, record, MissionState.COMPLETED)
    elif any(lg.state is LegState.FAILED for lg in record.legs):
        failed = next(lg for lg in reversed(record.legs) if lg.state is LegState.FAILED)
        await finish(planner, record, MissionState.FAILED, failed.error or "a leg failed")
    else:
        why = f"every leg ended with {len(left)} steps not flown"
        await finish(planner, record, MissionState.FAILED, record.error or why)


def refilling(planner: MissionPlanner, record: MissionRecord) -> bool:
    """Whether a refill of ``record``'s reports is outstanding: a leg whose drone is heard
    has a gap in its report numbers (issue 26: a mission ended while its refill was on the
    way, and the reports it brought were dropped). The drone is asked again every
    :data:`~.reconcile.GAP_ASK_S` and the mission settled again after each ask, for at
    most :data:`~.reconcile.GAP_HOLD_S` (a drone that cannot send them holds it no longer)."""
    now = time.monotonic()
    holding = False
    for leg in record.legs:
        if not reconcile.missing(leg.seqs) or not _may_still_send(planner, leg):
            planner.gap_since.pop(leg.leg_id, None)
            continue
        since = planner.gap_since.setdefault(leg.leg_id, now)
        if now - since >= reconcile.GAP_HOLD_S:
            log.warning(
                "mission %s: reports %s of %s never came; it ends without them",
                record.mission_id, reconcile.missing(leg.seqs), leg.leg_id,
            )  # fmt: skip
            continue
        holding = True
    if holding and record.mission_id not in planner.resettling:
        planner.resettling.add(record.mission_id)
        planner.spawn(settle_after_refill(planner, record), f"refill:{record.mission_id}")
    return holding


def _may_still_send(planner: MissionPlanner, leg: Leg) -> bool:
    """Whether ``leg``'s drone may still send the reports missing from it: it is heard, or,
    declared lost, it has sent a report of this leg within the last
    :data:`~.reconcile.GAP_HOLD_S`. A drone's backlog (its outbox, its bridge's queue) comes
    back with the link before any heartbeat does, and not always in order: with every drone
    declared lost while the ground's broker was down (chaos seed 108), the end of each leg came
    in before its middle, and the mission was failed on the gap between."""
    if leg.drone_id not in planner.lost:
        return True
    return bool(leg.reports) and time.time() - leg.reports[-1].received_at < reconcile.GAP_HOLD_S


async def settle_after_refill(planner: MissionPlanner, record: MissionRecord) -> None:
    """Ask again for the missing reports of ``record``'s legs, then settle it again."""
    try:
        for leg in record.legs:
            if reconcile.missing(leg.seqs) and _may_still_send(planner, leg):
                await reconcile.fill_gap(planner, leg)
        await asyncio.sleep(reconcile.GAP_ASK_S)
    finally:
        planner.resettling.discard(record.mission_id)
    async with planner.lock:
        await settle_locked(planner, record)


def holds_open(planner: MissionPlanner, record: MissionRecord, leg: Leg) -> bool:
    """Whether active ``leg`` keeps its mission open: its drone is heard, or it is lost with
    work nobody has taken over (the mission is then stalled until it is back). A lost
    drone's way out (going home, landing), or its leg with all its work done, holds nothing
    open."""
    if leg.drone_id not in planner.lost:
        return True
    if leg.role.outgoing or record.handed_over(leg):
        return False
    return bool(remaining(record.work, leg.indices, set(record.done)))


async def finish(
    planner: MissionPlanner, record: MissionRecord, state: MissionState, error: str | None = None
) -> None:
    """End ``record`` as ``state`` (with ``error``): written with its end time, and its log."""
    record.state = state
    record.ended_at = timestamp_s()
    record.error = error
    try:
        await planner.save(record)
        await planner.store.save_log(record.mission_id, build_log(record))
    except Exception as exc:  # a full disk: the record is written by the planner's flusher
        log.warning("mission %s %s, not written yet: %s", record.mission_id, state.value, exc)
    planner.emit("mission", **record.summary())
    log.info("mission %s %s", record.mission_id, state.value)
