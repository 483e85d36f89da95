"""How a drone's part of a mission ends: every mission ends with a safe action (issue 14).

Before, a drone that finished its share hovered where it was until its battery ran out (the
seed's missions ended with their last step). A mission now has an end action, ``rtl`` (return to
launch and land, the default, as ArduPilot's mission planners propose), ``land`` (where the work
ended) or ``hold`` (stay up, for an operator who will take the drone on); the planner appends it
to every share it sends, so the battery check at acceptance counts the way home too. A step list
that already ends on the ground (its last flying step is a land or an RTL) is left as it is.
"""

from __future__ import annotations

from typing import Any, Literal

from dronefleet.messaging.commands import Command

EndAction = Literal["rtl", "land", "hold"]

#: Steps that may follow a landing without taking off again.
_AFTER_LANDING = {Command.WAIT_FOR_FLIGHT, Command.DISARM, Command.SLEEP}
_LANDS = {Command.LAND, Command.RTL}


#: A drone sent home early: aborting a mission, a lost drone heard again (ground/planner/lost.py),
#: a drone handed over early (early.py). It lands at the nearest of the mission's rally points
#: when one is nearer than home (``rally``: chosen by the drone from where it really is, drone/
#: navigation.py), else at home.
GO_HOME = (
    {"command": Command.RTL.value, "rally": True},
    {"command": Command.WAIT_FOR_FLIGHT.value},
)


def ends_on_the_ground(steps: list[dict[str, Any]]) -> bool:
    """Whether ``steps`` end with the vehicle landing (land or RTL, then only waits)."""
    for step in reversed(steps):
        command = step.get("command")
        if command in _LANDS:
            return True
        if command not in _AFTER_LANDING:
            return False
    return False


def end_steps(action: EndAction, steps: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """What to append to ``steps`` so that they end with ``action`` (nothing if they end on the
    ground already, or for ``hold``)."""
    if action == "hold" or not steps or ends_on_the_ground(steps):
        return []
    command = Command.RTL if action == "rtl" else Command.LAND
    return [{"command": command.value}, {"command": Command.WAIT_FOR_FLIGHT.value}]
