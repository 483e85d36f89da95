"""A mission's progress as an operator watches it (issue 29; REST ``GET .../progress``).

Per drone: its share (the work steps and waypoints it was given, and how many it has done), the
step it flies now, what it is doing (flying, paused, handed over, done) and its time left
(ground/planner/eta.py); for the mission: how much of it is done, and its timeline
(ground/planner/timeline.py). Read from the record the planner holds; the estimates are the
only part computed, off the event loop.
"""

from __future__ import annotations

from typing import Any

from dronefleet.ground.planner.eta import Eta, current_step
from dronefleet.ground.planner.models import Leg, LegState, MissionRecord
from dronefleet.ground.planner.timeline import events_of
from dronefleet.messaging.commands import Command

#: What an operator calls a drone's part when its last leg ended so.
_ENDED = {
    LegState.COMPLETED: "done",
    LegState.FAILED: "failed",
    LegState.STOPPED: "stopped",
    LegState.REPLACED: "handed over",
}


def _doing(record: MissionRecord, legs: list[Leg], active: Leg | None) -> str:
    if active is not None:
        if active.paused:
            return "paused"
        if active.role.outgoing:
            return "leaving"  # replaced: going home or landing
        return "flying" if active.state is LegState.RUNNING else "sent"
    last = legs[-1]
    if last.role.outgoing or record.handed_over(last):
        return "handed over"
    return _ENDED.get(last.state, last.state.value)


def _current(record: MissionRecord, leg: Leg) -> dict[str, Any] | None:
    steps = leg.drone_steps(record.work)
    at = current_step(leg)
    if at >= len(steps):
        return None
    return {
        "drone_step": at,
        "drone_steps": len(steps),
        "index": leg.global_index(at),
        "command": str(steps[at].get("command")),
    }


def drone_progress(record: MissionRecord, etas: dict[str, Eta]) -> list[dict[str, Any]]:
    """Each drone of ``record``, in the order it joined: its share, step, state and time left."""
    required = set(record.required_indices())
    waypoints = {i for i in required if record.work[i].get("command") == Command.WAIT_FOR_FLIGHT}
    drones: dict[str, list[Leg]] = {}
    # Whose share each step is: who flew it, else the drone of the latest leg given it (a step
    # handed over is the replacement's share): a drone done with its part shows a full bar.
    owner: dict[int, str] = {}
    for leg in record.legs:
        drones.setdefault(leg.drone_id, []).append(leg)
        owner.update(dict.fromkeys(leg.indices, leg.drone_id))
    owner.update(record.done)
    answer = []
    for drone_id, legs in drones.items():
        done = {i for i, who in record.done.items() if who == drone_id}
        mine = {i for leg in legs for i in leg.indices if i in required and owner[i] == drone_id}
        given = mine | done
        active = next((leg for leg in legs if leg.active), None)
        eta = etas.get(active.leg_id) if active is not None else None
        answer.append(
            {
                "drone_id": drone_id,
                "role": (active or legs[-1]).role.value,
                "doing": _doing(record, legs, active),
                "steps": len(given),
                "steps_done": len(done),
                "waypoints": len(given & waypoints),
                "waypoints_reached": len(done & waypoints),
                "share": round(len(done) / len(given), 3) if given else 1.0,
                "current": _current(record, active) if active is not None else None,
                "paused": active.paused if active is not None else None,
                "eta_s": eta.eta_s if eta is not None else (0.0 if active is None else None),
                "eta_pending": eta.pending if eta is not None else False,
            }
        )
    return answer


def mission_progress(record: MissionRecord, etas: dict[str, Eta]) -> dict[str, Any]:
    """The whole progress view of ``record`` (its summary, drones, fraction done, timeline)."""
    required = set(record.required_indices())
    done = required & set(record.done)
    drones = drone_progress(record, etas)
    left = [d["eta_s"] for d in drones if d["current"] is not None]
    return {
        **record.summary(),
        "fraction_done": round(len(done) / len(required), 3) if required else 1.0,
        # The mission ends when its last drone does: the longest time left.
        "eta_s": None if record.terminal or None in left else max(left, default=0.0),
        "progress": drones,
        "events": [e.model_dump(mode="json") for e in events_of(record)],
    }
