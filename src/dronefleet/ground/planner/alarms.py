"""The alarms the drones send (``+/alarms/out``), as the Mission Planner reads them: each is kept
once in its mission's record; a CRITICAL one starts a replacement (ground/planner/replacement.py),
an OUT_MEASURE one grows the area (ground/planner/collaboration.py).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from dronefleet.ground.planner import inbound, replacement
from dronefleet.messaging.commands import AlarmLevel, Command
from dronefleet.messaging.status import Alarm

if TYPE_CHECKING:
    from dronefleet.ground.planner.service import MissionPlanner


async def on_alarm(planner: MissionPlanner, topic_name: str, payload: bytes) -> None:
    """A drone's alarm (``<id>/alarms/out``), as the broker delivered it."""
    alarm = inbound.read(planner, "alarm", Alarm, topic_name, payload)
    if alarm is None:
        return
    data = alarm.model_dump(mode="json", exclude_none=True)
    decided = None
    async with planner.lock:
        record, leg = planner.mission_of(alarm.drone_id, alarm.mission_id)
        if record is None or leg is None:
            planner.emit("alarm", **data)
            return
        if any(same_alarm(a, alarm) for a in record.alarms):
            return  # delivered again: it was acted on when it first came
        record.alarms.append(alarm)
        index = leg.global_index(alarm.step_index) if alarm.step_index is not None else None
        if index is not None and record.work[index].get("command") == Command.VIRTUALALARM:
            record.done.setdefault(index, alarm.drone_id)
        if alarm.level is AlarmLevel.CRITICAL and record.options.replacement:
            # Decided with the alarm, in one write: the alarm is acknowledged to the broker
            # only after this returns, so a ground killed before has it again, and one killed
            # after finds the handover decided (replacement.resume).
            decided = replacement.decide(planner, record, leg, alarm)
        if decided is None:
            await planner.save(record)
        else:
            await planner.send_leg(record, decided[1])  # written, then sent
    planner.emit("alarm", **{**data, "mission_id": record.mission_id})
    if decided is not None:
        handover, going = decided
        planner.spawn(replacement.assign_after(planner, record, handover), f"assign:{going.leg_id}")
    elif alarm.level is AlarmLevel.OUT_MEASURE and record.options.collaboration:
        from dronefleet.ground.planner import collaboration

        planner.spawn(collaboration.extend(planner, record, leg, alarm), f"extend:{alarm.drone_id}")


def same_alarm(a: Alarm, b: Alarm) -> bool:
    """Whether ``a`` and ``b`` are one alarm (delivered twice): the same drone, leg, level, step
    and vehicle time."""
    return (
        a.drone_id == b.drone_id
        and a.mission_id == b.mission_id
        and a.level is b.level
        and a.step_index == b.step_index
        and a.vehicle_time_s == b.vehicle_time_s
    )
