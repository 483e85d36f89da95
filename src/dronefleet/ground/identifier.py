"""Drone Identifier (seed 3.4.2.1, 4.2.1): who is connected, where, with what gear.

It listens to ``+/heartbeats/out`` on the ground broker, asks each new drone's Gear Manager for its
specifications and sensors (``<id>/gear/in``), marks drones ``lost`` after 3 silent heartbeat
intervals and ``online`` on the next heartbeat, and keeps the fleet in the ground state store.
Other ground components ask it over the broker (Fig. 4.31-4.32): a request on
``ground/identifier/in`` (``{"request_id", "query": "discover"|"drone", "drone_id", "reply_to"}``)
is answered on ``reply_to`` (default ``ground/identifier/out``) echoing the ``request_id``.
Fleet changes (a drone new, lost or back) are announced on ``ground/identifier/events``.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections import Counter
from typing import Any, Literal

from pydantic import Field

from dronefleet.clock import timestamp_s
from dronefleet.ground.fleet import MIN_LOST_AFTER_S, DroneRecord, DroneStatus, LenientHeartbeat
from dronefleet.ground.state import StateStore
from dronefleet.messaging.client import QOS_STREAM, BrokerClient
from dronefleet.messaging.codec import MessageError, decode_object
from dronefleet.messaging.common import Message, validate
from dronefleet.messaging.gear import GearQuery, GearRequest
from dronefleet.messaging.ground_events import FleetChange, FleetEvent
from dronefleet.messaging.log_throttle import LogThrottle
from dronefleet.messaging.rpc import Requester, RequestTimeout
from dronefleet.messaging.topics import (
    GROUND_PREFIX,
    IDENTIFIER_EVENTS,
    Channel,
    Direction,
    any_drone,
    ground,
    topic,
)

log = logging.getLogger(__name__)
_throttle = LogThrottle(
    log
)  # one line per kind per 10 s: junk on the broker must not flood the log

QUERY_TOPIC = ground("identifier", "in")
REPLY_TOPIC = ground("identifier", "out")
EVENTS_TOPIC = IDENTIFIER_EVENTS

#: How often each drone's record is written to the state store while nothing else changes.
PERSIST_EVERY_S = 5.0
GEAR_TIMEOUT_S = 5.0
GEAR_RETRY_S = 30.0


class DroneIdentifier:
    """The fleet, built from heartbeats and gear answers. ``start()``/``stop()`` it."""

    def __init__(
        self,
        broker_url: Any,
        state: StateStore,
        *,
        client_id: str,
        lost_after_s: float = MIN_LOST_AFTER_S,
    ) -> None:
        #: Heartbeats dropped, by why: malformed (or an id off the pattern, an absurd
        #: interval), or a drone speaking on another's topic (issue 12).
        self.dropped: Counter[str] = Counter()
        self.lost_after_s = lost_after_s  # at least this long unheard before "lost"
        self.client = BrokerClient(broker_url, client_id)
        self.requester = Requester(self.client)
        self.state = state
        self.fleet: dict[str, DroneRecord] = {}
        self._dirty: set[str] = set()
        self._persisted_at: dict[str, float] = {}
        self._gear_asked_at: dict[str, float] = {}
        self._tasks: list[asyncio.Task[None]] = []
        self._gear_tasks: set[asyncio.Task[None]] = set()
        self.dropped_queries = 0  # messages on ground/identifier/in that were not queries

    async def start(self) -> DroneIdentifier:
        started = timestamp_s()
        for data in await self.state.load_drones():
            with contextlib.suppress(ValueError):
                record = DroneRecord.model_validate(data)
                # After a ground restart give every drone 3 intervals to be heard again.
                if record.status is not DroneStatus.LOST:
                    record.last_seen = max(record.last_seen, started)
                self.fleet[record.drone_id] = record
        await self.client.subscribe(
            any_drone(Channel.HEARTBEATS), self._on_heartbeat, qos=QOS_STREAM
        )
        await self.client.subscribe(QUERY_TOPIC, self._on_query)
        await self.client.start()
        self._tasks = [
            asyncio.create_task(self._watch_liveness(), name="identifier:liveness"),
            asyncio.create_task(self._persist_loop(), name="identifier:persist"),
        ]
        return self

    async def stop(self) -> None:
        for task in [*self._tasks, *self._gear_tasks]:
            task.cancel()
        for task in [*self._tasks, *self._gear_tasks]:
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
        self._tasks = []
        await self._flush()
        await self.client.stop()

    # -- heartbeats ----------------------------------------------------------------------------
    async def _on_heartbeat(self, topic_name: str, payload: bytes) -> None:
        try:
            hb = validate(LenientHeartbeat, decode_object(payload))
        except MessageError as exc:
            self.dropped["malformed heartbeat"] += 1
            _throttle.log(
                logging.WARNING, "heartbeat", "dropping heartbeat on %s: %s", topic_name, exc
            )
            return
        if not topic_name.startswith(f"{hb.drone_id}/"):
            self.dropped["heartbeat on another drone's topic"] += 1
            _throttle.log(
                logging.WARNING,
                "heartbeat",
                "dropping heartbeat of %s sent on %s",
                hb.drone_id,
                topic_name,
            )
            return
        now = timestamp_s()
        record = self.fleet.get(hb.drone_id)
        if record is None:
            record = self.fleet[hb.drone_id] = DroneRecord.first(hb, now)
            log.info("drone %s joined the fleet", hb.drone_id)
            await self._announce(record, FleetChange.NEW)
        else:
            before = record.status
            came_back = record.observe(hb, now)
            if record.status is DroneStatus.AUTOPILOT_LINK_LOST and before is not record.status:
                log.warning("drone %s: its autopilot link is lost", hb.drone_id)
                await self._announce(record, FleetChange.AUTOPILOT_LINK_LOST)
            elif came_back or before is DroneStatus.AUTOPILOT_LINK_LOST:
                log.info("drone %s is online again", hb.drone_id)
                await self._announce(record, FleetChange.ONLINE)
        self._dirty.add(hb.drone_id)
        if record.specs is None or record.sensors is None:
            self._maybe_ask_gear(hb.drone_id, now)

    async def _watch_liveness(self) -> None:
        while True:
            await asyncio.sleep(0.05)
            now = timestamp_s()
            for record in list(self.fleet.values()):
                if record.status is not DroneStatus.LOST and now > record.deadline(
                    self.lost_after_s
                ):
                    record.status = DroneStatus.LOST
                    record.status_changed = now
                    self._dirty.add(record.drone_id)
                    log.warning(
                        "drone %s lost: no heartbeat for %.1f s",
                        record.drone_id,
                        now - record.last_seen,
                    )
                    await self._announce(record, FleetChange.LOST)
                    await self._flush([record.drone_id])

    async def _announce(self, record: DroneRecord, event: FleetChange) -> None:
        message = FleetEvent(event=event, drone_id=record.drone_id, drone=record.public())
        await self.client.publish(EVENTS_TOPIC, message, disposable=True)
        if event is not FleetChange.NEW:
            await self._flush([record.drone_id])

    # -- gear ----------------------------------------------------------------------------------
    def _maybe_ask_gear(self, drone_id: str, now: float) -> None:
        asked = self._gear_asked_at.get(drone_id)
        if asked is not None and now - asked < GEAR_RETRY_S:
            return
        self._gear_asked_at[drone_id] = now
        task = asyncio.create_task(self._ask_gear(drone_id), name=f"identifier:gear:{drone_id}")
        self._gear_tasks.add(task)
        task.add_done_callback(self._gear_tasks.discard)

    async def _ask_gear(self, drone_id: str) -> None:
        reply_pattern = any_drone(Channel.GEAR)
        gear_in = topic(drone_id, Channel.GEAR, Direction.IN)
        for query in (GearQuery.SPECS, GearQuery.SENSORS):
            try:
                reply = await self.requester.request(
                    gear_in,
                    reply_pattern,
                    GearRequest(query=query),
                    timeout_s=GEAR_TIMEOUT_S,
                    reply_topic=topic(drone_id, Channel.GEAR, Direction.OUT),
                )
            except RequestTimeout:
                log.info("drone %s did not answer the %s query; will ask again", drone_id, query)
                return
            record = self.fleet.get(drone_id)
            if record is None or not reply.get("ok", False):
                continue
            value = reply.get(query.value)
            if isinstance(value, dict):
                setattr(record, query.value, value)
                record.gear_updated = timestamp_s()
                self._dirty.add(drone_id)

    # -- queries from ground components --------------------------------------------------------
    def snapshot(self) -> list[dict[str, Any]]:
        return [self.fleet[k].public() for k in sorted(self.fleet)]

    async def _on_query(self, topic_name: str, payload: bytes) -> None:
        try:
            query = validate(IdentifierQuery, decode_object(payload))
        except MessageError as exc:
            # Not a query (a flood of junk here once made the identifier answer each piece).
            self.dropped_queries += 1
            _throttle.log(logging.WARNING, "query", "dropping identifier query: %s", exc)
            return
        answer: dict[str, Any] = {"request_id": query.request_id, "ok": True}
        if query.query == "discover":
            answer["drones"] = self.snapshot()
        else:
            record = self.fleet.get(query.drone_id or "")
            answer["drone"] = record.public() if record else None
        await self.client.publish(query.reply_to, answer)

    # -- persistence ---------------------------------------------------------------------------
    async def _persist_loop(self) -> None:
        while True:
            await asyncio.sleep(1.0)
            now = timestamp_s()
            due = [
                d for d in self._dirty if now - self._persisted_at.get(d, 0.0) >= PERSIST_EVERY_S
            ]
            if due:
                await self._flush(due)

    async def _flush(self, drone_ids: list[str] | None = None) -> None:
        ids = list(self._dirty) if drone_ids is None else drone_ids
        records = [self.fleet[d].model_dump(mode="json") for d in ids if d in self.fleet]
        if not records:
            return
        try:
            await self.state.save_drones(records)
        except Exception:  # a full disk must not stop the fleet from being tracked
            log.exception("could not save %d drone records", len(records))
            return
        now = timestamp_s()
        for d in ids:
            self._dirty.discard(d)
            self._persisted_at[d] = now


class IdentifierQuery(Message):
    """What ground components ask the Drone Identifier (``ground/identifier/in``)."""

    query: Literal["discover", "drone"]
    request_id: str = Field(min_length=1, max_length=64)
    drone_id: str | None = Field(default=None, max_length=64)
    reply_to: str = Field(default=REPLY_TOPIC, pattern=rf"^{GROUND_PREFIX}/[^#+]{{1,200}}$")


def identifier_query(query: str, drone_id: str | None = None) -> dict[str, Any]:
    """A query message for the Drone Identifier (the caller's Requester adds the request id)."""
    message: dict[str, Any] = {"query": query}
    if drone_id is not None:
        message["drone_id"] = drone_id
    return message
