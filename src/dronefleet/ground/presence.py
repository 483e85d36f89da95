"""One ground per planner session: a second ``dronefleet ground`` with the same planner session
on the same broker refuses to start.

The Mission Planner's broker session is persistent and keyed by a configured client id (``ground-
planner``), so that progress reports queued while the ground is down reach it when it is back. A
second ground with that id took the session over from the first ("performing take-over"): progress
reports were lost and a departing drone flew back to an old waypoint (issue 11). Every ground
therefore announces itself on ``ground/presence/<planner session id>``, retained, every
:data:`PRESENCE_S`. One that starts looks first: no announcement, or its own, and it goes on at
once; another ground's announcement must then be repeated live within :data:`STALE_AFTER_S` for
that ground to count as running (a ground that died leaves its last one behind). A ground that
stops clears it. Two grounds started within the same instant are not told apart.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import secrets
from typing import Any

from dronefleet import clock
from dronefleet.errors import Conflict
from dronefleet.messaging import topics
from dronefleet.messaging.client import BrokerClient

TOPIC = topics.ground("presence", "{planner_id}")  # one claim per planner session
#: Seconds between announcements.
PRESENCE_S = 2.0
#: An announcement not repeated within this long belongs to a ground that is gone.
STALE_AFTER_S = 2.5 * PRESENCE_S
#: How long a retained announcement may take to arrive after subscribing.
RETAINED_WAIT_S = 0.5


class GroundAlreadyRunning(Conflict, RuntimeError):
    """Another ground is serving this broker."""


class GroundPresence:
    def __init__(self, broker_url: Any, *, planner_id: str) -> None:
        self.instance = secrets.token_hex(6)
        self.planner_id = planner_id
        self.client = BrokerClient(broker_url, f"ground-presence-{self.instance}")
        if any(c in planner_id for c in "/+#"):
            raise ValueError(f"planner session id {planner_id!r} may not contain / + or #")
        self.topic = TOPIC.format(planner_id=planner_id)
        self._seen: asyncio.Queue[dict[str, Any]] = asyncio.Queue()
        self._task: asyncio.Task[None] | None = None

    async def start(self) -> None:
        """Claim the broker, or raise :class:`GroundAlreadyRunning` with who holds it."""
        await self.client.start()
        await self.client.subscribe(self.topic, self._on_presence)
        other = await self._other()
        if other is not None:
            await self.client.stop()
            raise GroundAlreadyRunning(
                f"another dronefleet ground is running on {self.client.url} (planner session "
                f"{other.get('planner_id')!r}); stop it first — two grounds would take each "
                "other's mission progress"
            )
        await self._announce()
        self._task = asyncio.create_task(self._announce_forever(), name="ground-presence")

    async def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
            self._task = None
            with contextlib.suppress(Exception):  # leave no claim behind
                await self.client.publish(self.topic, b"", retain=True, timeout_s=2.0)
        await self.client.stop()

    async def _other(self) -> dict[str, Any] | None:
        """Another running ground's announcement, or None. The first delivery after subscribing
        is the retained one (maybe left by a ground that died); any later one was published just
        now, so its ground is running."""
        try:
            async with asyncio.timeout(RETAINED_WAIT_S):
                await self._seen.get()
        except TimeoutError:
            return None  # no claim at all
        deadline = clock.monotonic() + STALE_AFTER_S
        while True:
            try:
                async with asyncio.timeout(max(0.0, deadline - clock.monotonic())):
                    found = await self._seen.get()
            except TimeoutError:
                return None  # only a stale claim: its ground is gone
            if found.get("instance") != self.instance:
                return found

    async def _on_presence(self, _topic: str, payload: bytes) -> None:
        if self._task is not None:
            return  # claimed: nothing to look for any more
        with contextlib.suppress(ValueError):
            found = json.loads(payload) if payload else None
            if isinstance(found, dict):
                self._seen.put_nowait(found)

    async def _announce(self) -> None:
        body = {"instance": self.instance, "planner_id": self.planner_id}
        await self.client.publish(self.topic, json.dumps(body).encode(), retain=True)

    async def _announce_forever(self) -> None:
        while True:
            await asyncio.sleep(PRESENCE_S)
            await self._announce()
