"""A mission's timeline: what happened to it, in order, in sentences an operator reads (issue 29).

The Mission Planner announces every change (:meth:`MissionPlanner.emit`: a drone paused or
resumed, an alarm, a handover, an expansion, the mission stalled or ended); :func:`note` keeps
the ones an operator must know about in the record (``MissionRecord.events``, durable with it),
saying what replacement and collaboration did — or that they were switched off and did nothing:
"co2 alarm on QUAD_1 (co2_ppm 1450 above its high bound 1000): area expanded 2 times, drones QUAD_2,
QUAD_3 called". :func:`events_of` adds what the record knows but nobody announced (an expansion
that failed) for the progress view (ground/planner/progress_view.py).
"""

from __future__ import annotations

from typing import Any

from dronefleet.clock import timestamp_s
from dronefleet.ground.planner.models import EventKind, Expansion, MissionEvent, MissionRecord
from dronefleet.messaging.commands import AlarmLevel
from dronefleet.messaging.status import Alarm

#: The mission states that end up in the timeline, as its event kinds.
_STATES = {
    "stalled": EventKind.STALLED,
    "completed": EventKind.COMPLETED,
    "failed": EventKind.FAILED,
    "stopped": EventKind.STOPPED,
}
_STATE_KINDS = frozenset({*_STATES.values(), EventKind.RUNNING})


def note(record: MissionRecord, event: str, data: dict[str, Any]) -> bool:
    """Add to ``record``'s timeline what ``event`` (with ``data``, as emitted) says; True when
    something was added (the record then needs saving)."""
    found = _event(record, event, data)
    if found is None:
        return False
    record.events.append(found)
    return True


def _event(record: MissionRecord, event: str, data: dict[str, Any]) -> MissionEvent | None:
    drone = data.get("drone_id")
    if event == "progress":
        return _progress(record, str(data.get("event")), drone, data.get("error"))
    if event == "alarm":
        return _alarm(record, data)
    if event == "handover":
        to, who = data.get("to_drone"), data.get("from_drone")
        if to is None:
            text = f"{who} could not be replaced: {data.get('error') or 'nobody free'}"
        else:
            early = " (early: before its battery runs low)" if data.get("kind") == "early" else ""
            steps = data.get("remaining_steps") or 0
            text = f"{who} replaced by {to}{early}: {data.get('reason')}; {steps} steps taken over"
        return _at(EventKind.HANDOVER, text, who, [to] if to else [])
    if event == "expansion":
        expansion = Expansion.model_validate(data)
        return _at(EventKind.EXPANSION, expansion_text(record, expansion), expansion.drone_id,
                   list(expansion.joined))  # fmt: skip
    if event == "mission":
        return _state(record, str(data.get("state")), data)
    return None


def _at(kind: EventKind, text: str, drone: str | None = None, drones: list[str] | None = None,
        at: float | None = None) -> MissionEvent:  # fmt: skip
    return MissionEvent(
        at=timestamp_s() if at is None else at, kind=kind, drone_id=drone, text=text,
        drones=drones or [],
    )  # fmt: skip


def _progress(record: MissionRecord, kind: str, drone: Any, error: Any) -> MissionEvent | None:
    if kind == "accepted" and not any(e.kind is EventKind.STARTED for e in record.events):
        return _at(EventKind.STARTED, f"started: {drone} accepted its share", drone)
    if kind == "paused":
        return _at(EventKind.PAUSED, f"{drone} paused: {error or 'taken over'}", drone)
    if kind == "resumed":
        return _at(EventKind.RESUMED, f"{drone} resumed its share", drone)
    return None


def _alarm(record: MissionRecord, data: dict[str, Any]) -> MissionEvent | None:
    level, drone = data.get("level"), data.get("drone_id")
    if data.get("mission_id") != record.mission_id or level not in set(AlarmLevel):
        return None
    text = f"{alarm_name(data)} on {drone}: {data.get('message') or level}"
    options = record.options
    if level == AlarmLevel.CRITICAL:
        text += (
            "; replacement is on: a drone is sought to take over" if options.replacement
            else "; replacement is off: nobody takes over"
        )  # fmt: skip
    elif level == AlarmLevel.OUT_MEASURE:
        if not options.collaboration:
            text += "; collaboration is off: the area stays as planned"
        elif record.area is None:
            text += "; a step list has no area to grow"
        elif len(record.expansions) >= options.max_expansions:
            text += f"; the area was grown {len(record.expansions)} time(s) already: no more"
        else:
            text += "; the area is grown around it"
    else:
        return None  # a WARNING (two drones close) is the alarm centre's, not the mission's
    return _at(EventKind.ALARM, text, drone)


def alarm_name(alarm: dict[str, Any]) -> str:
    """ "co2 alarm" for a reading's alarm (its field's first word), else "CRITICAL alarm"."""
    field = ((alarm.get("reading") or {}).get("field")) or ""
    if alarm.get("level") == AlarmLevel.OUT_MEASURE and isinstance(field, str) and field:
        return f"{field.split('_')[0]} alarm"
    return f"{alarm.get('level')} alarm"


def _the_alarm(record: MissionRecord, expansion: Expansion) -> Alarm | None:
    return next(
        (
            a
            for a in record.alarms
            if a.drone_id == expansion.drone_id and a.vehicle_time_s == expansion.alarm_vehicle_s
        ),
        None,
    )


def expansion_text(record: MissionRecord, expansion: Expansion) -> str:
    """What an expansion did, with the alarm that asked for it."""
    alarm = _the_alarm(record, expansion)
    what = alarm_name(alarm.model_dump(mode="json")) if alarm else "OUT_MEASURE alarm"
    said = f" ({alarm.message})" if alarm and alarm.message else ""
    head = f"{what} on {expansion.drone_id}{said}"
    if expansion.error:
        return f"{head}: area not expanded: {expansion.error}"
    factor = f" {expansion.area_factor:g} times" if expansion.area_factor else ""
    joined = expansion.joined
    called = f"drones {', '.join(joined)} called" if joined else "no other drone was free"
    return f"{head}: area expanded{factor} ({expansion.waypoints} waypoints), {called}"


def _state(record: MissionRecord, state: str, data: dict[str, Any]) -> MissionEvent | None:
    last = next((e.kind for e in reversed(record.events) if e.kind in _STATE_KINDS), None)
    kind = _STATES.get(state)
    if kind is None:  # running (or handed over) again after a stall
        if last is EventKind.STALLED and state in ("running", "handed_over"):
            return _at(EventKind.RUNNING, "running again")
        return None
    if kind is last:
        return None
    error = data.get("error")
    if kind is EventKind.COMPLETED:
        reached, planned = data.get("waypoints_reached"), data.get("waypoints")
        return _at(kind, f"completed: {reached}/{planned} waypoints")
    return _at(kind, f"{state}: {error}" if error else state)


def events_of(record: MissionRecord) -> list[MissionEvent]:
    """The timeline, oldest first: what was noted, and what the record says but nobody has
    announced yet: its end, expansions that failed (their time: their alarm's)."""
    events = list(record.events)
    if record.terminal:  # ended but not announced yet (it is, just after it is written)
        summary = record.summary()
        end = _state(record, record.state.value, summary)
        if end is not None:
            events.append(end.model_copy(update={"at": record.ended_at or end.at}))
    noted = {e.text for e in events if e.kind is EventKind.EXPANSION}
    for expansion in record.expansions:
        text = expansion_text(record, expansion)
        if expansion.error and text not in noted:
            alarm = _the_alarm(record, expansion)
            at = alarm.timestamp if alarm else None
            events.append(_at(EventKind.EXPANSION, text, expansion.drone_id, at=at))
    return sorted(events, key=lambda e: e.at if e.at is not None else float("inf"))
