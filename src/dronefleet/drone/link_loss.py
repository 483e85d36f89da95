"""What a drone does when it loses its link to the ground mid-mission (issue 13).

ArduPilot's GCS failsafe (FS_GCS_ENABLE, FS_GCS_TIMEOUT: 5 s by default) lets the operator
choose what the vehicle does when the ground station falls silent. Here the link is the drone's
broker connection: the Mission Worker's client. The default for a running mission is to go on
flying it — its reports wait in the outbox and the broker's queue, and the ground takes them
when the link is back — and an operator may choose instead to hold where it is or to return
home. Either ends the mission (reported ``stopped`` with the reason, sent when the link is back),
as a stop request would. Time is the vehicle's, as the autopilot's failsafe timer is.
"""

from __future__ import annotations

import asyncio
import logging
from enum import StrEnum
from typing import TYPE_CHECKING

from dronefleet.tasks import cancel_and_wait

if TYPE_CHECKING:
    from dronefleet.drone.mission_worker import MissionWorker

log = logging.getLogger(__name__)

#: Vehicle seconds without the broker before the action (ArduPilot's FS_GCS_TIMEOUT default).
DEFAULT_TIMEOUT_S = 5.0
#: Vehicle seconds between looks at the link.
POLL_S = 0.5


class LinkLossAction(StrEnum):
    CONTINUE = "continue"  # fly the mission on (the default)
    HOLD = "hold"  # stop the mission and hold position
    RTL = "rtl"  # stop the mission and return home


class LinkWatch:
    """Applies ``action`` once the Mission Worker's broker link has been down ``timeout_s``
    while a mission runs; once per outage."""

    def __init__(
        self,
        worker: MissionWorker,
        action: LinkLossAction = LinkLossAction.CONTINUE,
        timeout_s: float = DEFAULT_TIMEOUT_S,
    ) -> None:
        if timeout_s <= 0:
            raise ValueError(f"the link-loss timeout must be positive, not {timeout_s}")
        self.worker, self.action, self.timeout_s = worker, LinkLossAction(action), timeout_s
        self.actions_taken = 0
        self._task: asyncio.Task[None] | None = None

    def start(self) -> None:
        if self.action is not LinkLossAction.CONTINUE and self._task is None:
            self._task = asyncio.create_task(self._watch(), name="link-loss")

    async def stop(self) -> None:
        task, self._task = self._task, None
        await cancel_and_wait(task)

    async def _watch(self) -> None:
        clock, client = self.worker.clock, self.worker.client
        down_since: float | None = None
        acted = False
        while True:
            await clock.sleep(POLL_S)
            if client.connected:
                down_since, acted = None, False
                continue
            now = clock.now()
            down_since = now if down_since is None else down_since
            if not acted and self.worker.running and now - down_since >= self.timeout_s:
                acted = True
                await self.act(now - down_since)

    async def act(self, silent_s: float) -> None:
        """Stop the running mission and hold or return home."""
        why = f"link to the ground lost for {silent_s:.1f} s: {self.action.value}"
        log.warning("drone %s: %s", self.worker.controller.drone_id, why)
        self.actions_taken += 1
        await self.worker.abandon(why)
        navigation = self.worker.controller.navigation
        if self.action is LinkLossAction.RTL:
            await navigation.return_to_launch()
        elif self.worker.controller.fc.state().in_air:
            await navigation.hold()
