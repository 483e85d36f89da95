"""Direct commands and the mission flying (issue 26): who has the vehicle.

A direct command on ``control/in`` (Table 4.2) and the Mission Worker's steps both end in the
Navigation Processor. A direct ``takeoff`` to a drone mid-mission pulled it from 20 m to 13.4 m and
the mission flew on from there; a ``navigate`` sent it away until the next step brought it back.
So the Drone Controller, the one place every client's command passes (the ground's REST API,
``mosquitto_pub``, another ground), decides here:

* the commands that fly the vehicle somewhere or stop it (:data:`GUARDED`: ``takeoff``,
  ``navigate``, ``changeN``, ``changeE``, ``altitude``, ``disarm``, ``resetfc``) are refused while
  a mission flies it, with one sentence naming the mission and its step, unless the mission is
  paused or stopped first, or the command carries ``"force": true``;
* the safety commands (:data:`SAFETY`: ``land``, ``rtl``, and ``mode`` HOLD, LAND or RTL) are
  always obeyed (``mode`` GUIDED, which flies on to a goal, is guarded);
* a command obeyed while a mission flies (a safety command, or a forced one) first pauses the
  mission (reported ``paused``, with the command and who sent it: drone/takeover.py), so that the
  mission does not take the vehicle back at its next step; a resume from the ground flies on;
* the rest (``arm``, ``takepic``, ``objrequest``, ``rebuildtelemetry``) do not move the vehicle
  and are served as before.

The message models give ``force`` only to ``disarm`` and ``resetfc``; for the other guarded
commands the controller reads it here (:func:`parse_with_force`) until they carry it too.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

from dronefleet.errors import Conflict
from dronefleet.messaging.codec import MessageError
from dronefleet.messaging.commands import Command, SelectableMode, parse_control

#: Refused while a mission flies the vehicle, unless forced.
GUARDED = frozenset(
    {
        Command.TAKEOFF,
        Command.NAVIGATE,
        Command.CHANGE_N,
        Command.CHANGE_E,
        Command.ALTITUDE,
        Command.DISARM,
        Command.RESETFC,
        Command.MODE,  # GUIDED only: the other modes are safety commands (:func:`kind_of`)
    }
)
#: Always obeyed: the mission flying is paused first.
SAFETY = frozenset({Command.LAND, Command.RTL})
#: The ``mode`` values that stop, land or bring the vehicle home: safety commands.
SAFE_MODES = frozenset({SelectableMode.HOLD, SelectableMode.LAND, SelectableMode.RTL})


def is_safety(request: Any) -> bool:
    """Always obeyed (a mission flying is paused first): land, rtl, a mode that stops."""
    if request.command is Command.MODE:
        return request.value in SAFE_MODES
    return request.command in SAFETY


@dataclass(frozen=True, slots=True)
class FlyingMission:
    """The mission flying the vehicle now, as a refusal names it."""

    mission_id: str
    step_index: int | None  # the step being flown (its index in the mission), if one is
    last_index: int  # the index of the mission's last step

    def sentence(self, drone_id: str) -> str:
        step = self.step_index
        where = f" (step {step + 1} of {self.last_index + 1})" if step is not None else ""
        return (
            f"{drone_id} is flying mission {self.mission_id}{where}: "
            "pause or abort it first, or force"
        )

    def fields(self) -> dict[str, Any]:
        return {
            "mission_id": self.mission_id,
            "step_index": self.step_index,
            "step_count": self.last_index + 1,
        }


class MissionGate(Protocol):
    """What the controller asks of the Mission Worker (drone/mission_worker.py)."""

    def flying(self) -> FlyingMission | None:
        """The mission flying the vehicle now (not paused, not ended), or None."""
        ...

    async def yield_to(self, command: str, note: str) -> None:
        """Pause the flying mission for a direct ``command`` (``note``: who sent it, forced or
        not), reported ``paused``; returns once it no longer flies."""
        ...


class MissionBusy(Conflict):
    """A guarded command refused because a mission flies the vehicle."""

    def __init__(self, drone_id: str, mission: FlyingMission) -> None:
        super().__init__(mission.sentence(drone_id))
        self.mission = mission


def parse_with_force(data: dict[str, Any]) -> tuple[Any, bool]:
    """A control request and whether it is forced. ``force`` is read on every guarded command,
    also those whose message model has no such field (it is taken out before they are
    validated); elsewhere it is the model's business (refused where it has no meaning)."""
    if "force" not in data or data.get("command") not in GUARDED:
        request = parse_control(data)
        return request, bool(getattr(request, "force", False))
    try:
        request = parse_control(data)
    except MessageError:
        rest = {k: v for k, v in data.items() if k != "force"}
        request = parse_control(rest)  # raises the message's own error, if it has one
        force = data["force"]
        if not isinstance(force, bool):
            raise MessageError("force: must be true or false") from None
        return request, force
    return request, bool(getattr(request, "force", False))


async def mind_the_mission(
    gate: MissionGate | None, drone_id: str, request: Any, forced: bool
) -> None:
    """Raise :class:`MissionBusy` for a guarded command, not forced, while a mission flies; for
    a safety or forced command, pause the mission first. Anything else passes."""
    command = request.command
    safety = is_safety(request)
    if gate is None or (command not in GUARDED and not safety):
        return
    mission = gate.flying()
    if mission is None:
        return
    if not safety and not forced:
        raise MissionBusy(drone_id, mission)
    sender = getattr(request, "sender", None) or "an unnamed client"
    note = f"sent by {sender}" if safety else f"forced by {sender}"
    what = f"mode {request.value}" if command is Command.MODE else str(command)
    await gate.yield_to(what, note)
