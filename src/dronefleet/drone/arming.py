"""Arming Switch (seed 3.3.2.2, 4.1.2.4): tracks the arming state and changes it on request.

The seed needed an Arduino to emulate the sticks' arming frame because dRonin refused arming over
USB; here the backend does it (MAVLink arms by command, the simulator by call). The safety rule is
ours: disarming in flight stops the motors, so it is refused unless forced.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from dronefleet.drone.takeover import ModeLedger
from dronefleet.vehicle.base import FcRefused, FlightController


class ArmingSwitch:
    def __init__(
        self,
        fc: FlightController,
        on_event: Callable[..., Any] | None = None,
        modes: ModeLedger | None = None,
    ) -> None:
        self.fc = fc
        self.modes = modes or ModeLedger(fc)  # arming may switch modes (MAVLink: GUIDED first)
        self._on_event = on_event or (lambda *a, **k: None)

    @property
    def armed(self) -> bool:
        return self.fc.state().armed

    async def arm(self) -> dict[str, Any]:
        if self.fc.state().armed:
            return {"armed": True, "note": "already armed"}
        started = self.fc.clock.now()
        self._on_event("arming", requested_s=started)
        async with self.modes.choosing():
            await self.fc.arm()
        took = self.fc.clock.now() - started
        self._on_event("armed", took_s=took)
        return {"armed": True, "arming_time_s": round(took, 3)}

    async def disarm(self, *, force: bool = False) -> dict[str, Any]:
        state = self.fc.state()
        if not state.armed and not state.arming:
            return {"armed": False, "note": "already disarmed"}
        if state.in_air and not force:
            raise FcRefused(
                "refusing to disarm in flight: the motors would stop; land first, "
                "or send force=true to disarm anyway"
            )
        async with self.modes.choosing():
            await self.fc.disarm(force=force)
        self._on_event("disarmed", forced=force, in_air=state.in_air)
        return {"armed": False, "forced": force}
