"""How a drone's part of a mission ends: every mission ends with a safe action (issue 14).

Before, a drone that finished its share hovered where it was until its battery ran out (the
seed's missions ended with their last step). A mission now has an end action, ``rtl`` (return to
launch and land, the default, as ArduPilot's mission planners propose), ``land`` (where the work
ended) or ``hold`` (stay up, for an operator who will take the drone on); the planner appends it
to every share it sends, so the battery check at acceptance counts the way home too. A step list
that already ends on the ground (its last flying step is a land or an RTL) is left as it is.

Drones that end together must not come home together (issue 28): ArduPilot's RTL flew three
vehicles with homes 6 m apart home at the same 20 m, 3.9 m apart. A plan that sends several
drones home gives each a return layer of its own (:func:`return_layers`: 4 m apart, the first
:data:`RETURN_CLEARANCE_M` above the higher of the work and the autopilot's RTL altitude), and
each flies its way home as steps on it (:func:`layered_return`): up over its last work point,
across to above its home, then the autopilot's RTL from there, which keeps that height (RTL_ALT
is the least it climbs to) and only comes down. A drone that would come down near another
still landing waits at its layer first (ground/planner/deconflict/).
"""

from __future__ import annotations

from typing import Any, Literal

from dronefleet.geo.types import LLA
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


#: The first return layer's height above the higher of the work and the RTL altitude (m).
RETURN_CLEARANCE_M = 5.0
#: Between two return layers: the 3 m vertical minimum and a metre of altitude error (m), as
#: the transit layers (ground/planner/deconflict/).
RETURN_LAYER_STEP_M = 4.0


def return_layers(count: int, base_m: float) -> list[float]:
    """Heights of ``count`` return layers above home, the lowest :data:`RETURN_CLEARANCE_M`
    over ``base_m`` (e.g. 20, 24, 28 m for work at 10 m and ArduPilot's 15 m RTL_ALT)."""
    return [base_m + RETURN_CLEARANCE_M + RETURN_LAYER_STEP_M * k for k in range(count)]


def layered_return(
    last: tuple[float, float] | None, home: LLA, height_m: float
) -> list[dict[str, Any]]:
    """The way home on a layer of its own: up over the last work point ``last`` (lat, lon),
    across to above ``home`` at ``height_m``, then RTL (down at home)."""
    wait = {"command": Command.WAIT_FOR_FLIGHT.value}
    steps: list[dict[str, Any]] = []
    for lat, lon in ([last] if last is not None else []) + [(home.lat, home.lon)]:
        steps += [
            {"command": Command.NAVIGATE.value, "lat": lat, "lon": lon, "altitude_delta": height_m},
            dict(wait),
        ]
    return [*steps, {"command": Command.RTL.value}, dict(wait)]


def is_layered_return(end: list[dict[str, Any]]) -> bool:
    """Whether ``end`` is a :func:`layered_return` (navigates, then RTL)."""
    commands = [s.get("command") for s in end]
    return (
        len(commands) >= 4
        and commands[-2:] == [Command.RTL, Command.WAIT_FOR_FLIGHT]
        and commands[0] == Command.NAVIGATE
    )
