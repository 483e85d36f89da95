"""Distance-triggered camera: photograph every N metres without stopping (fly-through surveys).

Like MAVLink's ``MAV_CMD_DO_SET_CAM_TRIGG_DIST``: the Drone Controller watches the distance flown
and asks the Gear Manager for a picture each time another N metres are behind it. The seed stopped
at each photo (5.2); flying through is what makes a survey twice as fast.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Awaitable, Callable
from typing import Any

from dronefleet.geo.ned import lla_to_ned
from dronefleet.vehicle.base import FlightController

log = logging.getLogger(__name__)


class CameraTrigger:
    def __init__(
        self,
        fc: FlightController,
        capture: Callable[[], Awaitable[dict[str, Any]]],
        *,
        poll_s: float = 0.05,
    ) -> None:
        self.fc = fc
        self.capture = capture
        self.poll_s = poll_s
        self.distance_m = 0.0
        self.pictures: list[dict[str, Any]] = []
        self._told = 0  # how many of them a step report has listed (:meth:`untold`)
        self._task: asyncio.Task[None] | None = None
        self._travelled = 0.0
        self._last: Any = None
        # Held while a picture is being taken: stopping waits for it instead of cancelling it
        # half way (the camera has taken it and kept the file; a cancelled wait for its answer
        # left it out of the list, and the ground's gallery without it).
        self._shooting = asyncio.Lock()

    @property
    def active(self) -> bool:
        return self._task is not None and not self._task.done()

    async def set_distance(self, distance_m: float) -> dict[str, Any]:
        await self.stop()
        self.distance_m = distance_m
        if distance_m > 0:
            self._task = asyncio.create_task(self._run(distance_m), name="camera-trigger")
            # The first picture is taken where the trigger is set, as autopilots do.
            await self._shoot()
        return {
            "trigger_distance_m": distance_m,
            "pictures": len(self.pictures),
            "captures": self.untold(),
        }

    def untold(self) -> list[dict[str, Any]]:
        """The capture records of the pictures taken since the last call: each step report
        lists the ones before it, so the ground's photo gallery gets every one (issue 14)."""
        new = [c for c in self.pictures[self._told :] if c]
        self._told = len(self.pictures)
        return new

    def reset(self) -> None:
        """A new mission: no pictures yet."""
        self.pictures = []
        self._told = 0

    async def stop(self) -> None:
        if self._task is not None:
            async with self._shooting:  # a picture being taken is finished (and listed) first
                self._task.cancel()
                with contextlib.suppress(asyncio.CancelledError, Exception):
                    await self._task
            self._task = None
            # The loop polls; a picture that fell due since its last look is still taken.
            if self._advance() >= self.distance_m > 0:
                await self._shoot()
            self._travelled = 0.0

    async def _shoot(self) -> None:
        try:
            self.pictures.append((await self.capture()).get("capture") or {})
        except Exception as exc:  # a missed picture must not stop the flight
            log.warning("distance-triggered picture failed: %s", exc)

    def _advance(self) -> float:
        """Add the distance flown since the last look; return the distance since the last shot."""
        here = lla_to_ned(self.fc.position(), self.fc.home())
        if self._last is not None:
            self._travelled += (here - self._last).horizontal_m
        self._last = here
        return self._travelled

    async def _run(self, distance_m: float) -> None:
        self._travelled, self._last = 0.0, None
        self._advance()
        while True:
            await self.fc.clock.sleep(self.poll_s)
            async with self._shooting:  # cancelled while waiting for it: nothing has changed
                if self._advance() >= distance_m:
                    self._travelled -= distance_m
                    await self._shoot()
