"""The progress reports the drones send on their legs (``+/mission/out``), as the Mission
Planner reads them: each step reported is kept in its mission's record (ground/planner/progress.py),
a gap in the report numbers is asked for again (ground/planner/reconcile.py), a lost drone's
takeover and a failing drone's handover move on, and the mission is settled
(ground/planner/settling.py). A report of an ended mission is kept and changes nothing else.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

from dronefleet.ground.planner import inbound, lost, paths, reconcile, replacement
from dronefleet.ground.planner.mission_log import build_log
from dronefleet.ground.planner.models import Leg, MissionRecord
from dronefleet.ground.planner.progress import apply_progress, note_seq
from dronefleet.messaging.missions import MissionProgress, ProgressEvent

if TYPE_CHECKING:
    from dronefleet.ground.planner.service import MissionPlanner

log = logging.getLogger(__name__)


async def on_progress(planner: MissionPlanner, topic_name: str, payload: bytes) -> None:
    """A drone's report on its leg (``<id>/mission/out``), as the broker delivered it."""
    msg = inbound.read(planner, "progress", MissionProgress, topic_name, payload)
    if msg is None:
        return
    mission_id = planner.leg_missions.get(msg.mission_id)
    if mission_id is None:
        return  # not one of ours (a mission sent by hand, or the demo)
    async with planner.lock:
        record = planner.missions[mission_id]
        leg = record.leg(msg.mission_id)
        if leg is None or leg.drone_id != msg.drone_id:
            return
        if record.terminal:
            await late(planner, record, leg, msg)
            return
        if reconcile.answers_a_report_request(msg):
            planner.spawn(reconcile.forgotten(planner, record, leg), f"forgotten:{leg.leg_id}")
            return
        if msg.event is ProgressEvent.ACCEPTED:
            planner.start_delays.started(leg.leg_id, msg.vehicle_time_s)
        if apply_progress(record, leg, msg):  # a step reported for the first time
            paths.add_point(record, leg.drone_id, msg.vehicle_time_s, msg.position)
        if note_seq(leg, msg.seq):
            planner.spawn(reconcile.fill_gap(planner, leg), f"gap:{leg.leg_id}")
        try:
            await planner.save(record)
        except Exception as exc:  # a full disk: the report is kept and written when it can be
            log.warning("mission %s: report not written yet: %s", record.mission_id, exc)
        # A lost drone's replacement that started on its work: the takeover has happened.
        await lost.commit_started(planner, record, leg)
        # A drone taken over that flew on unheard: its replacement flies the rest only.
        lost.flew_unheard(planner, record, leg)
        # A failing drone that accepted its recovery: all its reports are in, so its steps
        # not flown are known; they are handed over now.
        ready = replacement.ready_on(record, leg)
        if ready is not None:
            planner.spawn(replacement.assign(planner, record, ready), f"assign:{leg.leg_id}")
    data = msg.model_dump(mode="json", exclude_none=True)
    planner.emit("progress", **{**data, "mission_id": mission_id, "leg_id": leg.leg_id})
    await after_progress(planner, record, leg, msg)
    if msg.event is ProgressEvent.STEP and leg.active:
        from dronefleet.ground.planner import early

        if leg.leg_id in planner.checking:  # checked again as soon as the running check ends
            planner.check_again.add(leg.leg_id)
            return
        planner.checking.add(leg.leg_id)
        planner.spawn(early.check(planner, record, leg), f"early:{leg.leg_id}")


async def after_progress(
    planner: MissionPlanner, record: MissionRecord, leg: Leg, msg: MissionProgress
) -> None:
    """Close the mission when nothing is left to fly, or fail it when a leg failed."""
    async with planner.lock:
        await planner.settle_locked(record)


async def late(
    planner: MissionPlanner, record: MissionRecord, leg: Leg, msg: MissionProgress
) -> None:
    """(The lock held.) A report of a leg of an ended mission: a lost drone heard again
    (what it flew unheard, its way home), or reports asked for again answered after the end.
    It is kept in the record, as every report a drone sends is (issue 26); the mission's
    state and end stay as they are (a report that would pause or resume it changes
    nothing)."""
    if reconcile.answers_a_report_request(msg):
        return
    if msg.event not in (ProgressEvent.PAUSED, ProgressEvent.RESUMED) and apply_progress(
        record, leg, msg
    ):
        paths.add_point(record, leg.drone_id, msg.vehicle_time_s, msg.position)
    if note_seq(leg, msg.seq) and leg.drone_id not in planner.lost:
        planner.spawn(reconcile.fill_gap(planner, leg), f"gap:{leg.leg_id}")
    await planner.save(record)
    await planner.store.save_log(record.mission_id, build_log(record))
    log.info(
        "mission %s (%s): report %s of %s after its end kept",
        record.mission_id, record.state.value, msg.seq, leg.leg_id,
    )  # fmt: skip
