"""Takeover: the vehicle's flight mode changed and this drone did not change it (issue 10).

Another ground station (a DO_SET_MODE from QGroundControl or MAVProxy), an RC pilot's mode switch
or the autopilot itself (ArduPilot's battery, GCS or fence failsafe switching to RTL or LAND;
UAVTalk's FlightStatus.FlightMode set by another station) may take the vehicle mid-mission. A
Mission Worker that flew on would fight them: its next ``navigate`` switches back to GUIDED. So a
takeover pauses the mission (drone/mission_worker.py), says who or what took over, and leaves the
vehicle to them until the operator resumes or aborts it from the ground.

How it is told apart from our own changes: every flight-controller call that may change the mode
(the Navigation Processor's and Arming Switch's, the on-board mission start) runs inside
:meth:`ModeLedger.choosing`, after which the ledger keeps the mode the vehicle is in: the mode we
chose — or, while the vehicle does not show it yet, the mode it was asked for
(``fc.expected_mode()``: PX4 acknowledges a take-off before its HEARTBEAT says AUTO.TAKEOFF).
Armed and in the air, outside a choice in progress, in another mode: taken over. It is
looked at every :data:`POLL_S` vehicle seconds, the telemetry period (ArduPilot, and our simulated
Copter, send a HEARTBEAT at once when the mode changes; otherwise at 1 Hz).
"""

from __future__ import annotations

import contextlib
from collections.abc import AsyncIterator
from dataclasses import dataclass
from typing import Any

from dronefleet.geo.types import LLA
from dronefleet.messaging.commands import Command
from dronefleet.vehicle.base import FlightController, FlightMode

#: Vehicle seconds between looks at the mode: the drone's telemetry period (5 Hz).
POLL_S = 0.2
#: Who took over when the autopilot gives no reason of its own.
SOMEONE_ELSE = "another ground station or the RC pilot"
#: A pause asked for on ``mission/in``: the drone holds, as if it had been taken over.
OPERATOR = "the operator"
#: A direct command obeyed mid-mission (a land, an RTL, a forced one): the command flies the
#: vehicle, the mission waits (drone/direct_commands.py). ``mode`` is the command, ``reason``
#: who sent it.
DIRECT = "a direct command"
#: The autopilot stopped answering mid-mission (issue 26): the mission waits for the operator,
#: who may resume it once the link is back (on the ground after a reboot: refused, abort it).
LINK_LOST = "the autopilot link"


@dataclass(frozen=True, slots=True)
class Takeover:
    mode: str  # as the autopilot names it (LOITER, RTL, ...)
    by: str  # "the autopilot" or SOMEONE_ELSE
    reason: str | None  # the autopilot's own words, if it gave any
    vehicle_time_s: float

    def describe(self) -> str:
        if self.by == OPERATOR:
            return "paused by the operator: holding"
        if self.by == LINK_LOST:
            return f"paused: the autopilot link is lost ({self.reason})"
        if self.by == DIRECT:
            who = f" ({self.reason})" if self.reason else ""
            return f"paused for a direct {self.mode} command{who}"
        why = f" ({self.reason})" if self.reason else ""
        return f"taken over: flight mode {self.mode} set by {self.by}{why}"

    def fields(self) -> dict[str, str]:
        said = {"reason": self.reason} if self.reason else {}
        return {"mode": self.mode, "by": self.by, **said}


class ModeLedger:
    """The flight mode this drone last chose, and whether it is choosing one now."""

    def __init__(self, fc: FlightController) -> None:
        self.fc = fc
        self.chosen: FlightMode | None = None
        self._choosing = 0

    @contextlib.asynccontextmanager
    async def choosing(self) -> AsyncIterator[None]:
        """Wrap a call that may change the mode: whatever mode it leaves is ours."""
        self._choosing += 1
        try:
            yield
        finally:
            self._choosing -= 1
            self.chosen = self._expected() or self.fc.state().mode

    def adopt(self) -> None:
        """Count the mode the vehicle is in now as ours (the operator resumed in it)."""
        self.chosen = self.fc.state().mode

    def _expected(self) -> FlightMode | None:
        """The mode the flight controller commanded and its autopilot does not show yet (PX4
        acknowledges a take-off before its HEARTBEAT shows AUTO.TAKEOFF): ours, not a takeover."""
        expected = getattr(self.fc, "expected_mode", None)
        return expected() if callable(expected) else None

    def takeover(self) -> Takeover | None:
        """A takeover now, or None (on the ground, nothing chosen yet, or a choice under way)."""
        if self._choosing or self.chosen is None or self._expected() is not None:
            return None
        state = self.fc.state()
        if not (state.armed and state.in_air) or state.mode is self.chosen:
            return None
        name = getattr(self.fc, "mode_name", None)
        mode = name() if callable(name) else state.mode.value
        cause = getattr(self.fc, "takeover_cause", None)
        reason = cause() if callable(cause) else None
        by = "the autopilot" if reason else SOMEONE_ELSE
        return Takeover(mode, by, reason, round(self.fc.clock.now(), 3))


@dataclass(slots=True)
class Paused:
    """A mission paused by a takeover: what is left of it, and who took the vehicle."""

    mission_id: str
    count: int
    start_index: int
    steps: list[tuple[int, Any]]  # the mission's steps, labelled with their indices
    done: set[int]  # indices reported done
    takeover: Takeover
    # Where the mission was flying to (and whether it was landing): a direct command flown
    # meanwhile moves the Navigation Processor's goal, a resume flies back to this one.
    goal: LLA | None = None
    landing: bool = False

    def left(self) -> list[tuple[int, Any]]:
        """The steps to fly on resuming: those not done, from an absolute ``navigate`` again
        when the first is the ``wait_for_flight`` that followed it (going there again changes
        nothing; a relative move would go twice as far, so its goal is flown to instead, by
        :meth:`~dronefleet.drone.navigation.NavigationProcessor.resume`)."""
        left = [(i, step) for i, step in self.steps if i not in self.done]
        if not left or left[0][1].command is not Command.WAIT_FOR_FLIGHT:
            return left
        before = [(i, step) for i, step in self.steps if i < left[0][0]]
        if before and before[-1][1].command is Command.NAVIGATE:
            return [before[-1], *left]
        return left

    def resume_plan(self, *, grounded: bool) -> tuple[list[tuple[int, Any]], str | None, bool]:
        """What a resume flies: the steps, why it cannot (None: it can), and whether the
        vehicle is first taken back to the goal it was flying to. On the ground only a mission
        that had not taken off yet goes on (armed again if it was disarmed meanwhile)."""
        left = self.left()
        first = left[0][1].command if left else None
        starts = first in (Command.ARM, Command.TAKEOFF)
        if grounded and not starts:
            return left, "the vehicle is on the ground", False
        if grounded and first is Command.TAKEOFF:
            left = [s for s in self.steps if s[1].command is Command.ARM][-1:] + left
        return left, None, not starts and first is not Command.NAVIGATE
