"""Broker-to-database Connector (seed 3.4.2.3, 4.2.2.2): telemetry from the broker into the store.

It is handed every drone's telemetry (``+/telemetry/out``) by the ground's Fleet Inbox
(ground/inbox.py: read, validated and checked against its topic once for every ground service),
turns each message into a :class:`TelemetryPoint` and writes them in batches, one transaction
each (every ``flush_s`` or ``batch_size`` points), so a thousand drones at 5 Hz cost a few
database writes per second. Fields of no known schema, impossible values and unbelievable
timestamps are dropped and counted here, never stored (messaging/telemetry_schema.py), never
fatal; malformed messages are the inbox's to count.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from typing import Any

from dronefleet import clock
from dronefleet.ground.inbox import FleetInbox
from dronefleet.ground.telemetry.store import TelemetryPoint, TelemetryStore
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.nats_link import NatsLink
from dronefleet.messaging.status import Telemetry
from dronefleet.messaging.telemetry_schema import believable_timestamp, screen

log = logging.getLogger(__name__)

#: Points held in memory while the store is away; the oldest are dropped beyond this.
MAX_BUFFER = 200_000
#: Points a write takes at most. An SQLite store's index by drone and time gets each new row
#: in its drone's place, so every drone's page is written again at each commit: the fewer the
#: commits, the less each row costs (2,000 drones' rows into a table of 500,000: 22 us a row in
#: batches of 1,000, 13 in batches of 10,000, SQLite alone). At 5 Hz from 2,000 drones a write
#: every ``flush_s`` is then 5,000 points, not 2,000 every 0.2 s; a replica of 9,000 drones on
#: 4 hosts (bench/replica_share.py) stored 89.5 % of its telemetry with 2,000, 99.5-100 % with it.
BATCH_SIZE = 10_000


class TelemetryConnector:
    def __init__(
        self,
        broker_url: Any,
        store: TelemetryStore,
        *,
        client_id: str,
        flush_s: float = 0.5,
        batch_size: int = BATCH_SIZE,
        inbox: FleetInbox | None = None,
        from_inbox: bool = True,
    ) -> None:
        #: Where the telemetry comes from; alone (no ground's inbox given), an inbox of its own.
        self.inbox = inbox or FleetInbox(broker_url, client_id=client_id)
        self._own_inbox = inbox is None
        #: False: the inbox's stream is not stored; another source calls :meth:`take` (a
        #: replica's share of the fleet's telemetry, ground/telemetry/shared_ingest.py).
        self.from_inbox = from_inbox
        self.store = store
        self.flush_s = flush_s
        self.batch_size = batch_size
        self.received = 0
        self.stored = 0
        self.dropped = 0  # whole messages: unbelievable timestamps, nothing storable, overflow
        self.unknown_fields = 0  # fields of no known schema, left out (messaging/telemetry_schema)
        self.out_of_range = 0  # values no vehicle or sensor can have, left out
        self._buffer: list[TelemetryPoint] = []
        #: When (clock.monotonic) the oldest point not yet written came; None when none waits.
        self.pending_since: float | None = None
        #: The store's last write failure (when, why), until a write succeeds (the ground's
        #: health reports it: ground/manager/health.py).
        self.write_error: tuple[float, str] | None = None
        self._wake = asyncio.Event()
        self._task: asyncio.Task[None] | None = None

    @property
    def client(self) -> BrokerClient | NatsLink:
        """The broker connection its telemetry comes on (the ground's health watches it)."""
        return self.inbox.telemetry.client

    async def start(self) -> TelemetryConnector:
        if self.from_inbox:
            # Partitioned (ground/partition.py), each drone's telemetry is stored by its owner.
            self.inbox.telemetry.direct("telemetry connector", self.take, takes="own")
        if self._own_inbox:
            await self.inbox.start()
        self._task = asyncio.create_task(self._flush_loop(), name="telemetry:flush")
        return self

    async def stop(self) -> None:
        await self.inbox.telemetry.detach("telemetry connector")
        if self._own_inbox:
            await self.inbox.stop()
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
            self._task = None
        await self.flush()

    def take(self, msg: Telemetry) -> None:
        """One message as the inbox read it: buffered for the next batch, if worth storing."""
        if not believable_timestamp(msg.timestamp, clock.timestamp_s()):
            self.dropped += 1
            return
        # Only the schema's names are kept, and every one is a name the stores accept
        # (store.FIELD_RE; tests/unit/ground/test_fleet_inbox.py checks it once, not here per
        # message: it was half of this method's time).
        fields, unknown, out_of_range = screen(msg.fields)
        self.unknown_fields += unknown
        self.out_of_range += out_of_range
        if not fields:
            self.dropped += 1
            return
        self.received += 1
        if not self._buffer:
            self.pending_since = clock.monotonic()
        self._buffer.append(TelemetryPoint(msg.drone_id, round(msg.timestamp * 1e6), fields))
        if len(self._buffer) > MAX_BUFFER:
            excess = len(self._buffer) - MAX_BUFFER
            del self._buffer[:excess]
            self.dropped += excess
        if len(self._buffer) >= self.batch_size:
            self._wake.set()

    async def _flush_loop(self) -> None:
        while True:
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(self.flush_s):
                    await self._wake.wait()
            self._wake.clear()
            await self.flush()

    async def flush(self) -> None:
        """Write what is buffered now; on a store error keep it for the next try. What comes
        during the writes waits for the next flush: written at once, it made a batch of what
        came during one write, and at 12,500 points a second the store's runs (a drone's points
        of a batch, ground/telemetry/sqlite_store.py) were of one point, 1.06 on average."""
        todo = len(self._buffer)
        while todo > 0 and self._buffer:
            batch = self._buffer[: min(self.batch_size, todo)]
            try:
                await self.store.write(batch)
            except Exception as exc:
                log.warning("telemetry store %s: %s; will retry", self.store.url, exc)
                self.write_error = (clock.monotonic(), str(exc) or type(exc).__name__)
                return
            del self._buffer[: len(batch)]
            todo -= len(batch)
            self.stored += len(batch)
            self.write_error = None
            # What is left came after the batch written: counted as waiting from now.
            self.pending_since = clock.monotonic() if self._buffer else None

    @property
    def pending(self) -> int:
        """Points received and not yet written."""
        return len(self._buffer)
