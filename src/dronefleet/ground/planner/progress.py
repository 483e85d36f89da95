"""What a drone's progress report changes in its mission record (the Mission Planner's bookkeeping).

A report moves its leg along (accepted, completed, failed, stopped), pauses or resumes its mission
(a drone taken over by someone else, drone/takeover.py) and records a step as done, once: QoS 1
is at-least-once, and a report asked for again after a reconnect comes twice.
"""

from __future__ import annotations

import bisect

from dronefleet.clock import timestamp_s
from dronefleet.ground.planner.measurements import measured
from dronefleet.ground.planner.models import (
    Leg,
    LegState,
    MissionRecord,
    MissionState,
    StepReport,
)
from dronefleet.messaging.missions import MissionProgress, ProgressEvent


def apply_progress(record: MissionRecord, leg: Leg, msg: MissionProgress) -> bool:
    """Apply ``msg`` to ``leg`` and ``record``; True when it recorded a step for the first time."""
    event = msg.event
    if event is ProgressEvent.ACCEPTED and leg.state is LegState.SENT:
        leg.state = LegState.RUNNING
        leg.started_vehicle_s = msg.vehicle_time_s
        if record.started_at is None:
            record.started_at = timestamp_s()
    elif event is ProgressEvent.STEP and msg.step_index is not None:
        return _step_done(record, leg, msg, msg.step_index)
    elif not leg.active:
        return False
    elif event is ProgressEvent.COMPLETED:
        leg.state = LegState.COMPLETED
        leg.ended_vehicle_s = msg.vehicle_time_s
    elif event in (ProgressEvent.FAILED, ProgressEvent.REJECTED):
        leg.state = LegState.FAILED
        leg.error = msg.error
        leg.ended_vehicle_s = msg.vehicle_time_s
    elif event is ProgressEvent.STOPPED:
        leg.state = LegState.STOPPED
        leg.ended_vehicle_s = msg.vehicle_time_s
    elif event is ProgressEvent.PAUSED:
        leg.paused = msg.error or "taken over"
        record.state, record.error = MissionState.PAUSED, f"{leg.drone_id}: {leg.paused}"
    elif event is ProgressEvent.RESUMED:
        leg.paused = None
        if not any(lg.paused for lg in record.active_legs()):
            record.error = None
            record.state = MissionState.HANDED_OVER if record.handovers else MissionState.RUNNING
    return False


def note_seq(leg: Leg, seq: int | None) -> bool:
    """Record report number ``seq`` of ``leg``; True when some number below the highest is
    missing (reports lost on the way: the planner asks the drone for them again)."""
    if seq is not None and seq not in leg.seqs:
        bisect.insort(leg.seqs, seq)
    return bool(leg.seqs) and leg.seqs[-1] > len(leg.seqs)


def _step_done(record: MissionRecord, leg: Leg, msg: MissionProgress, drone_step: int) -> bool:
    if any(r.drone_step == drone_step for r in leg.reports):
        return False  # a duplicate delivery (QoS 1 is at-least-once)
    index = leg.global_index(drone_step)
    position = msg.position.model_dump(mode="json") if msg.position else None
    leg.reports.append(
        StepReport(
            index=index,
            drone_step=drone_step,
            command=str(msg.command),
            position=position,
            started_s=msg.step_started_s,
            duration_s=msg.step_duration_s,
            vehicle_time_s=msg.vehicle_time_s,
            measured=measured(msg.result),
        )
    )
    if index is not None:
        record.done.setdefault(index, leg.drone_id)
    return True
