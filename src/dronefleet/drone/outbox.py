"""What the drone must tell the ground, sent in order without ever holding up the mission.

Issue 13: a drone's broker went away for 30 s and the drone stopped flying its mission, because
the Mission Worker awaited each progress report's publish. Now a report is posted to the outbox
and the mission flies on; one sender task publishes the posted messages in order (QoS 1), waiting
out the outage, so the ground gets every report when the broker is back. The outbox is bounded
(:data:`MAX_PENDING`; past it the oldest is dropped and counted, never silently); the Mission
Worker also keeps every report of its last missions for the ground to ask again (``report``).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections import deque

from pydantic import BaseModel

from dronefleet.messaging.client import QOS_COMMAND, BrokerClient, BrokerUnavailable

log = logging.getLogger(__name__)

#: Messages kept while the broker is away: a 10,000-step mission's reports and then some.
MAX_PENDING = 50_000


class Outbox:
    def __init__(self, client: BrokerClient, *, max_pending: int = MAX_PENDING) -> None:
        self.client = client
        self._pending: deque[tuple[str, BaseModel]] = deque(maxlen=max_pending)
        self._ready = asyncio.Event()
        self._sender: asyncio.Task[None] | None = None
        self.dropped = 0  # the oldest, pushed out of a full outbox
        self.sent = 0

    @property
    def pending(self) -> int:
        return len(self._pending)

    def post(self, topic_name: str, message: BaseModel) -> None:
        """Queue ``message`` for ``topic_name``; returns at once."""
        if len(self._pending) == self._pending.maxlen:
            self.dropped += 1
            log.warning("outbox full: the oldest message is dropped (%d so far)", self.dropped)
        self._pending.append((topic_name, message))
        self._ready.set()
        if self._sender is None or self._sender.done():
            self._sender = asyncio.create_task(self._send(), name="outbox")

    async def drain(self, timeout_s: float | None = None) -> bool:
        """Wait until everything posted is sent (or ``timeout_s`` passes); True if it was."""
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(timeout_s):
                while self._pending:
                    await asyncio.sleep(0.01)
                return True
        return False

    async def close(self) -> None:
        if self._sender is not None:
            self._sender.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._sender
            self._sender = None

    async def _send(self) -> None:
        while True:
            if not self._pending:
                self._ready.clear()
                await self._ready.wait()
                continue
            topic_name, message = self._pending[0]
            try:
                await self.client.publish(topic_name, message, qos=QOS_COMMAND)
            except BrokerUnavailable:
                return  # the client was stopped: what is left stays pending
            if self._pending and self._pending[0][1] is message:
                self._pending.popleft()
            self.sent += 1
