"""Broker-to-database Connector (seed 3.4.2.3, 4.2.2.2): telemetry from the broker into the store.

Subscribes ``+/telemetry/out`` on the ground broker, turns each message into a
:class:`TelemetryPoint`, and writes them in batches (every ``flush_s`` or ``batch_size`` points)
so a hundred drones at 5 Hz cost a few database writes per second. Malformed messages, fields of
no known schema, impossible values and unbelievable timestamps are dropped and counted, never
stored (messaging/telemetry_schema.py), never fatal.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from typing import Any

from pydantic import ConfigDict

from dronefleet import clock
from dronefleet.ground.telemetry.store import FIELD_RE, TelemetryPoint, TelemetryStore
from dronefleet.messaging.client import QOS_STREAM, BrokerClient
from dronefleet.messaging.codec import MessageError, decode_object
from dronefleet.messaging.common import validate
from dronefleet.messaging.status import Telemetry
from dronefleet.messaging.telemetry_schema import believable_timestamp, screen
from dronefleet.messaging.topics import Channel, any_drone

log = logging.getLogger(__name__)

#: Points held in memory while the store is away; the oldest are dropped beyond this.
MAX_BUFFER = 200_000


class _LenientTelemetry(Telemetry):
    model_config = ConfigDict(extra="ignore")


class TelemetryConnector:
    def __init__(
        self,
        broker_url: Any,
        store: TelemetryStore,
        *,
        client_id: str,
        flush_s: float = 0.5,
        batch_size: int = 2_000,
    ) -> None:
        self.client = BrokerClient(broker_url, client_id)
        self.store = store
        self.flush_s = flush_s
        self.batch_size = batch_size
        self.received = 0
        self.stored = 0
        self.dropped = 0  # whole messages
        self.unknown_fields = 0  # fields of no known schema, left out (messaging/telemetry_schema)
        self.out_of_range = 0  # values no vehicle or sensor can have, left out
        self._buffer: list[TelemetryPoint] = []
        self._wake = asyncio.Event()
        self._task: asyncio.Task[None] | None = None

    async def start(self) -> TelemetryConnector:
        await self.client.subscribe(
            any_drone(Channel.TELEMETRY), self._on_telemetry, qos=QOS_STREAM
        )
        await self.client.start()
        self._task = asyncio.create_task(self._flush_loop(), name="telemetry:flush")
        return self

    async def stop(self) -> None:
        await self.client.stop()
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
            self._task = None
        await self.flush()

    async def _on_telemetry(self, topic_name: str, payload: bytes) -> None:
        try:
            msg = validate(_LenientTelemetry, decode_object(payload))
        except MessageError as exc:
            self.dropped += 1
            log.debug("dropping telemetry on %s: %s", topic_name, exc)
            return
        if not topic_name.startswith(f"{msg.drone_id}/"):
            self.dropped += 1
            return
        if not believable_timestamp(msg.timestamp, clock.timestamp_s()):
            self.dropped += 1
            return
        fields, unknown, out_of_range = screen(msg.fields)
        self.unknown_fields += unknown
        self.out_of_range += out_of_range
        fields = {k: v for k, v in fields.items() if FIELD_RE.match(k)}
        if not fields:
            self.dropped += 1
            return
        self.received += 1
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
        """Write what is buffered; on a store error keep it for the next try."""
        while self._buffer:
            batch = self._buffer[: self.batch_size]
            try:
                await self.store.write(batch)
            except Exception as exc:
                log.warning("telemetry store %s: %s; will retry", self.store.url, exc)
                return
            del self._buffer[: len(batch)]
            self.stored += len(batch)
