"""Step order: a step list that cannot be flown in the order given is refused (issue 14).

The Mission Worker flies steps one after the other and trusts their order; a list that navigates
after a land with no new take-off, or before the drone (on the ground) has taken off, used to be
accepted and then failed or stalled in flight. Each share is walked here as the drone would fly
it, from the drone's state now (on the ground or in the air), through its preparation, the work
and its end, and the first step that cannot follow the ones before is refused with its index in
the caller's list and the reason (REST 422, ``step_index``), before anything is sent.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from dronefleet.errors import InvalidInput
from dronefleet.messaging.commands import Command

#: Steps that move the vehicle: only in the air.
_MOVES = {Command.NAVIGATE, Command.CHANGE_N, Command.CHANGE_E, Command.ALTITUDE}
#: Work done at a waypoint: meaningless once the drone has landed (until it takes off again).
_WORK = {Command.TAKEPIC, Command.READ_SENSORS, Command.CAMERA_TRIGGER}
_LANDS = {Command.LAND, Command.RTL}


class StepOrderError(InvalidInput):
    """A step that cannot follow the ones before it; ``step_index`` is its place in the list."""


def check_order(
    steps: Sequence[dict[str, Any]],
    *,
    airborne: bool,
    armed: bool,
    index_of: Sequence[int | None],
) -> None:
    """Walk ``steps`` (a share as flown) from the drone's state; raise :class:`StepOrderError`
    at the first step out of order. ``index_of[k]`` is step ``k``'s index in the caller's list
    (None for steps the planner added, which are right by construction)."""
    armed = armed or airborne
    landed_at: tuple[int, str] | None = None  # (caller's index, command) of the last landing
    for k, step in enumerate(steps):
        command = step.get("command")
        why = _problem(command, airborne=airborne, armed=armed, landed_at=landed_at)
        index = index_of[k] if k < len(index_of) else None
        if why is not None and index is not None:
            raise StepOrderError(f"step {index} ({command}): {why}", step_index=index)
        if command == Command.ARM:
            armed = True
        elif command == Command.TAKEOFF:
            airborne, armed, landed_at = True, True, None
        elif command in _LANDS:
            airborne = False
            landed_at = (index if index is not None else k, str(command))
        elif command == Command.DISARM:
            armed = False


def _problem(
    command: Any, *, airborne: bool, armed: bool, landed_at: tuple[int, str] | None
) -> str | None:
    if command == Command.TAKEOFF and not armed:
        return "the drone is not armed here: put an 'arm' step before the take-off"
    if command == Command.DISARM and airborne:
        return "the drone is flying here: land it before disarming (a disarm in flight drops it)"
    if airborne:
        return None
    if landed_at is not None and (command in _MOVES or command in _WORK):
        where, how = landed_at
        return (
            f"the drone is on the ground after the {how} at step {where}: "
            "take off again first (arm, takeoff)"
        )
    if command in _MOVES:
        return "the drone is on the ground here: take off first (arm, takeoff)"
    return None
