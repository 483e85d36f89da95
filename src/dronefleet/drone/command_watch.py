"""Command watch (issue 29): a direct move is answered when accepted, and reported when done.

The Drone Controller answers a control command on ``control/out`` as soon as the autopilot has
taken it (seed 4.1.2: the answer echoes the request id). For a command that moves the vehicle
that is not the end: a take-off climbs for seconds, a goto flies, a landing descends. The
operator's console said "navigate done" when the drone had merely accepted it. So the answer to
such a command says ``done: false``, and this watch follows the vehicle until the move has
ended, then sends the same request id again with ``done: true`` and how it ended:

* ``reached``: the goal (take-off height, goto, relative move, GUIDED) is reached by Algorithm 1
  (the Navigation Processor's tolerance cylinder, as ``wait_for_flight``);
* ``landed``: a land or RTL ended on the ground;
* ``holding``: a HOLD has stopped the vehicle;
* ``superseded``: another command (or a mission step) gave the vehicle another goal first
  (``ok`` false, nothing failed: the operator sees the later command instead);
* ``timed out``: not done within :data:`WATCH_LIMIT_S` vehicle seconds (``ok`` false).

One watch at a time per drone: a newer command ends the older one as superseded.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Awaitable, Callable
from typing import Any

from dronefleet.clock import wait_until
from dronefleet.drone.navigation import NavigationProcessor
from dronefleet.geo.types import LLA
from dronefleet.messaging.commands import Command, SelectableMode

log = logging.getLogger(__name__)

#: Longest a move is followed (vehicle seconds): a 5 km goto at 10 m/s is 500 s.
WATCH_LIMIT_S = 900.0
#: How often the vehicle is looked at (vehicle seconds).
POLL_S = 0.25
#: Ground speed under which a HOLD counts as holding (m/s).
STILL_MPS = 0.3

#: Called with (request_id, command, ok, outcome, result) when a move ends.
Report = Callable[[str, str, bool, str, dict[str, Any]], Awaitable[None]]


def watched_kind(request: Any) -> str | None:
    """What ends ``request``: "goal", "ground" or "still"; None: done when answered."""
    command = request.command
    if command in {
        Command.TAKEOFF,
        Command.NAVIGATE,
        Command.CHANGE_N,
        Command.CHANGE_E,
        Command.ALTITUDE,
    }:
        return "goal"
    if command in {Command.LAND, Command.RTL}:
        return "ground"
    if command is Command.MODE:
        return {
            SelectableMode.GUIDED: "goal",
            SelectableMode.HOLD: "still",
            SelectableMode.LAND: "ground",
            SelectableMode.RTL: "ground",
        }[request.value]
    return None


class CommandWatch:
    """Follows the last direct move until it ends, then reports it (see the module doc)."""

    def __init__(self, nav: NavigationProcessor, report: Report) -> None:
        self.nav = nav
        self.fc = nav.fc
        self.report = report
        self._task: asyncio.Task[None] | None = None
        self._current: tuple[str, str] | None = None  # (request_id, command) being watched
        self._reports: set[asyncio.Task[None]] = set()  # superseded reports on their way

    def watch(self, request_id: str, command: str, kind: str) -> None:
        """Start following a move just accepted; an older one ends as superseded."""
        self.stop_watching(superseded=True)
        goal = self.nav.goal
        self._current = (request_id, command)
        self._task = asyncio.create_task(
            self._follow(request_id, command, kind, goal), name=f"watch:{command}"
        )

    def stop_watching(self, *, superseded: bool) -> None:
        task, current = self._task, self._current
        self._task = self._current = None
        if task is None or task.done():
            return
        task.cancel()
        if superseded and current is not None:
            # Reported on a task of its own: the caller is answering its own command now.
            report = asyncio.ensure_future(
                self.report(current[0], current[1], False, "superseded", {})
            )
            self._reports.add(report)
            report.add_done_callback(self._reports.discard)

    async def close(self) -> None:
        task = self._task
        self.stop_watching(superseded=False)
        if task is not None:
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task

    async def _follow(self, request_id: str, command: str, kind: str, goal: LLA | None) -> None:
        clock = self.fc.clock
        other = False

        def ended() -> bool:
            nonlocal other
            if kind == "goal" and self.nav.goal != goal:
                other = True  # a mission step, or a command not watched, moved the goal
                return True
            if kind == "goal":
                return self.fc.state().in_air and self.nav.goal_reached()
            if kind == "ground":
                return not self.fc.state().in_air
            return self.fc.velocity().horizontal_m < STILL_MPS

        done = await wait_until(clock, ended, poll_s=POLL_S, timeout_s=WATCH_LIMIT_S)
        if self._current == (request_id, command):
            self._current = self._task = None
        here = self.fc.position()
        home = self.fc.home()
        result = {
            "position": {
                "lat": here.lat,
                "lon": here.lon,
                "alt_m": round(here.alt_m, 2),
                "above_home_m": round(here.alt_m - home.alt_m, 2),
            }
        }
        if other:
            await self.report(request_id, command, False, "superseded", result)
        elif not done:
            await self.report(request_id, command, False, "timed out", result)
        else:
            outcome = {"goal": "reached", "ground": "landed", "still": "holding"}[kind]
            await self.report(request_id, command, True, outcome, result)
