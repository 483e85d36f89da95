"""Drone Identifier (seed 3.4.2.1, 4.2.1): who is connected, where, with what gear.

It reads every drone's heartbeats (``+/heartbeats/out``) from the ground's Fleet Inbox
(ground/inbox.py: read and validated once for every ground service), asks each new drone's Gear
Manager for its specifications and sensors (``<id>/gear/in``), marks drones ``lost`` after 3 of
their declared heartbeat intervals of silence in the ground's own awake time (ground/fleet.py: a
ground that was stalled, deaf or restarting declares nobody lost for it) and ``online`` on the
next heartbeat (the silence of a broker cluster failing over, messaging/node_watch.py, is not
counted either), and keeps the fleet in the ground state store. Other ground components ask it
over the broker (Fig. 4.31-4.32): a request on
``ground/identifier/in`` (``{"request_id", "query": "discover"|"drone", "drone_id", "reply_to"}``)
is answered on ``reply_to`` (default ``ground/identifier/out``) echoing the ``request_id``.
Fleet changes (a drone new, lost or back) are announced on ``ground/identifier/events``.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
from collections.abc import Callable
from typing import Any, Literal

from pydantic import Field

from dronefleet.clock import timestamp_s
from dronefleet.ground.fleet import (
    MIN_LOST_AFTER_S,
    TICK_S,
    AwakeClock,
    DroneRecord,
    DroneStatus,
)
from dronefleet.ground.inbox import FleetInbox
from dronefleet.ground.state import StateStore
from dronefleet.messaging.bridge import BRIDGE_RESTART_MAX_S
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.codec import MessageError, decode_object
from dronefleet.messaging.common import Message, validate
from dronefleet.messaging.gear import GearQuery, GearRequest
from dronefleet.messaging.ground_events import FleetChange, FleetEvent
from dronefleet.messaging.log_throttle import LogThrottle
from dronefleet.messaging.node_watch import NodeWatch
from dronefleet.messaging.rpc import Requester, RequestTimeout
from dronefleet.messaging.status import Heartbeat, Telemetry
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
#: Records dumped and saved at a time (about 5 ms of the event loop each).
PERSIST_CHUNK = 100
GEAR_TIMEOUT_S = 5.0
GEAR_RETRY_S = 30.0
#: Liveness ticks in a row that must come on time before anyone may be declared lost.
STEADY_TICKS = 2
#: Awake seconds after the ground's heartbeat subscription is in place again (a reconnect, not
#: the first) during which nobody is declared lost: when the ground's broker itself restarted,
#: every drone's link to it was cut too, and a bridged drone comes back only at its bridge's
#: next attempt (up to BRIDGE_RESTART_MAX_S). Chaos seed 108: the ground broker down 13 s;
#: after it came back, the bridged drones were silent some seconds more, one was declared lost,
#: confirmed, taken over and sent home with no cause of its own.
RECONNECT_GRACE_S = BRIDGE_RESTART_MAX_S + 2.0
#: Awake seconds between whole walks of the fleet when no drone can be due (a bound, in case a
#: record changed other than by a heartbeat).
SCAN_EVERY_S = 1.0


class DroneIdentifier:
    """The fleet, built from heartbeats and gear answers. ``start()``/``stop()`` it."""

    def __init__(
        self,
        broker_url: Any,
        state: StateStore,
        *,
        client_id: str,
        lost_after_s: float = MIN_LOST_AFTER_S,
        inbox: FleetInbox | None = None,
    ) -> None:
        #: Where the heartbeats come from, read and checked once (malformed ones, or a drone
        #: speaking on another's topic, are dropped and counted there: issue 12); alone (no
        #: ground's inbox given), an inbox of its own.
        self.inbox = inbox or FleetInbox(broker_url, client_id=f"{client_id}-inbox")
        self._own_inbox = inbox is None
        self.lost_after_s = lost_after_s  # at least this long unheard before "lost"
        self.client = BrokerClient(broker_url, client_id)
        #: A broker cluster's nodes: while it fails over after losing one, drones on every
        #: node may be cut off, and that silence is not theirs (as the ground's own deafness).
        self.nodes = NodeWatch(broker_url, f"{client_id}-node")
        self.requester = Requester(self.client)
        self.state = state
        self.fleet: dict[str, DroneRecord] = {}
        self._dirty: set[str] = set()
        self._persisted_at: dict[str, float] = {}
        #: Whether this ground saves ``drone_id``'s record: among replicas that share the fleet
        #: by drone (ground/partition.py), its owner's does; every replica keeps every record.
        self.persists: Callable[[str], bool] = lambda _drone_id: True
        self._gear_asked_at: dict[str, float] = {}
        self._tasks: list[asyncio.Task[None]] = []
        self._gear_tasks: set[asyncio.Task[None]] = set()
        self.dropped_queries = 0  # messages on ground/identifier/in that were not queries
        #: The ground's awake time (fleet.AwakeClock): what a drone's silence is counted in.
        self.awake = AwakeClock()
        self._connections = 0  # the broker link whose subscription silence is counted from
        self._steady = 0  # liveness ticks in a row that came on time
        self._grace_until = 0.0  # awake time before which nobody is declared lost (a reconnect)
        #: Awake time before which no drone can be due (the earliest deadline at the last scan,
        #: lowered by every heartbeat since), and when the fleet was last scanned whole: a tick
        #: walks the fleet only when someone may be due, or a second after the last walk
        #: (issue 27: walking 1000 records every 50 ms cost 14 % of a loaded ground's loop).
        self._due_from = -math.inf
        self._scanned_at = -math.inf

    async def start(self) -> DroneIdentifier:
        for data in await self.state.load_drones():
            with contextlib.suppress(ValueError):
                record = DroneRecord.loaded(data)
                self.fleet[record.drone_id] = record
        self.inbox.heartbeats.direct("identifier-heard", self._heard)
        self.inbox.heartbeats.queued("identifier", self._on_heartbeat)
        self.inbox.telemetry.direct("identifier", self._on_telemetry)
        await self.client.subscribe(QUERY_TOPIC, self._on_query)
        await self.client.start()
        await self.nodes.start()
        if self._own_inbox:
            await self.inbox.start()
        # Connected means subscribed (messaging/client.py makes every subscription first): only
        # from now on can silence be heard, so only from now on does it count (issue 26: the
        # grace after a restart began before the subscription, and a drone was lost for it).
        # The heartbeats' subscription is the inbox's (its heartbeats' connection).
        self.awake = AwakeClock()
        self._listening(self.inbox.heartbeats.client.connections)
        self._tasks = [
            asyncio.create_task(self._watch_liveness(), name="identifier:liveness"),
            asyncio.create_task(self._persist_loop(), name="identifier:persist"),
        ]
        return self

    def _listening(self, connections: int) -> None:
        """The subscription is (again) in place: every drone not lost gets its whole
        :meth:`~DroneRecord.lost_after_s` of awake time, from now, to be heard."""
        again = self._connections > 0  # a reconnect: the broker may have dropped everyone
        self._connections = connections
        now = self.awake.now()
        if again:
            self._grace_until = now + RECONNECT_GRACE_S
        for record in self.fleet.values():
            record.heard_at(now)
        self._due_from = -math.inf

    async def stop(self) -> None:
        for task in [*self._tasks, *self._gear_tasks]:
            task.cancel()
        for task in [*self._tasks, *self._gear_tasks]:
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
        self._tasks = []
        await self.inbox.heartbeats.detach("identifier-heard")
        await self.inbox.heartbeats.detach("identifier")
        await self.inbox.telemetry.detach("identifier")
        if self._own_inbox:
            await self.inbox.stop()
        await self._flush()
        await self.nodes.stop()
        await self.client.stop()

    # -- heartbeats ----------------------------------------------------------------------------
    def _heard(self, hb: Heartbeat) -> None:
        """A heartbeat received (quick: called at once for each, before it is queued): its drone
        is heard now. What it says is taken on the identifier's own worker, which a ground
        short of CPU ran 25 s behind (bench/ground_capacity.py, 1000 drones on a host loaded 9:
        155 drones declared lost while their heartbeats waited in the queue, or were pushed
        out of it): the ground's backlog is no drone's silence."""
        record = self.fleet.get(hb.drone_id)
        if record is not None:
            record.heard_at(self.awake.now())

    async def _on_heartbeat(self, hb: Heartbeat) -> None:
        """A heartbeat as the inbox read it (valid, on its own drone's topic); its drone was
        counted heard when it arrived (:meth:`_heard`)."""
        now, awake = timestamp_s(), self.awake.now()
        record = self.fleet.get(hb.drone_id)
        if record is None:
            record = self.fleet[hb.drone_id] = DroneRecord.first(hb, now, awake)
            log.info("drone %s joined the fleet", hb.drone_id)
            await self._announce(record, FleetChange.NEW)
        else:
            before = record.status
            came_back = record.observe(hb, now)  # heard at its arrival (_heard), not now
            if record.status is DroneStatus.AUTOPILOT_LINK_LOST and before is not record.status:
                log.warning("drone %s: its autopilot link is lost", hb.drone_id)
                await self._announce(record, FleetChange.AUTOPILOT_LINK_LOST)
            elif came_back or before is DroneStatus.AUTOPILOT_LINK_LOST:
                log.info("drone %s is online again", hb.drone_id)
                await self._announce(record, FleetChange.ONLINE)
        self._due_from = min(self._due_from, record.due_at(self.lost_after_s))
        self._dirty.add(hb.drone_id)
        if record.specs is None or record.sensors is None:
            self._maybe_ask_gear(hb.drone_id, now)

    def _on_telemetry(self, msg: Telemetry) -> None:
        """A telemetry message (quick: called at once for each): the drone's newest position."""
        record = self.fleet.get(msg.drone_id)
        if record is not None:
            record.track(msg.vehicle_time_s, msg.fields)

    async def _watch_liveness(self) -> None:
        while True:
            await asyncio.sleep(TICK_S)
            for record in self.check_liveness():
                await self._announce(record, FleetChange.LOST)

    def check_liveness(self, now: float | None = None) -> list[DroneRecord]:
        """One liveness tick (every :data:`~dronefleet.ground.fleet.TICK_S`): count the ground's
        awake time and mark lost every drone silent for its
        :meth:`~dronefleet.ground.fleet.DroneRecord.lost_after_s` of it. Time the ground was
        stalled (this tick late) or deaf (its broker link down, or a broker cluster failing over
        after a node's loss: messaging/node_watch.py) does not count, and after a
        reconnect every drone's silence is counted afresh. Nobody is declared lost on a tick
        that came late or right after one: what arrived during the stall (heartbeats waiting in
        the socket or the subscription's queue) is read first. Returns the drones newly lost."""
        heard = self.inbox.heartbeats.client  # the heartbeats' subscription
        listening = heard.connected and not self.nodes.failing_over(now)
        if listening and heard.connections != self._connections:
            self._listening(heard.connections)  # (re)subscribed: heard from now on
        awake = self.awake.tick(now, listening=listening)
        if self.awake.last_stall_s > 1.0:
            # INFO: nothing for an operator to do about it (a loaded host's start-up stalls),
            # and the ground's own health and the drones' status already account for it.
            _throttle.log(
                logging.INFO,
                "stall",
                "the ground was stalled %.1f s (its event loop late): not counted against any "
                "drone's silence",
                self.awake.last_stall_s,
            )
        self._steady = self._steady + 1 if listening and self.awake.last_stall_s == 0 else 0
        if self._steady < STEADY_TICKS or awake < self._grace_until:
            return []
        if awake < self._due_from and awake - self._scanned_at < SCAN_EVERY_S:
            return []
        self._scanned_at, self._due_from = awake, math.inf
        lost = []
        for record in list(self.fleet.values()):
            if not record.due(awake, self.lost_after_s):
                if record.status is not DroneStatus.LOST:
                    self._due_from = min(self._due_from, record.due_at(self.lost_after_s))
            else:
                record.status = DroneStatus.LOST
                record.status_changed = timestamp_s()
                self._dirty.add(record.drone_id)
                log.warning(
                    "drone %s lost: no heartbeat for %.1f s of the ground's awake time "
                    "(%.1f s wall); it declares one every %.3g s",
                    record.drone_id,
                    record.silent_s(awake),
                    record.seen_ago_s(),
                    record.heartbeat_interval_s,
                )
                lost.append(record)
        return lost

    async def _announce(self, record: DroneRecord, event: FleetChange) -> None:
        message = FleetEvent(
            event=event, drone_id=record.drone_id, drone=record.public(self.lost_after_s)
        )
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
        return [self.fleet[k].public(self.lost_after_s) for k in sorted(self.fleet)]

    async def _on_query(self, topic_name: str, payload: bytes) -> None:
        try:
            query = validate(IdentifierQuery, decode_object(payload))
        except MessageError as exc:
            # Not a query (a flood of junk here once made the identifier answer each piece).
            self.dropped_queries += 1
            _throttle.log(logging.WARNING, "query", "dropping identifier query: %s", exc)
            return
        answer = {"request_id": query.request_id, **self.answer(query.query, query.drone_id)}
        await self.client.publish(query.reply_to, answer)

    def answer(self, query: str, drone_id: str | None = None) -> dict[str, Any]:
        """What a query is answered: ``discover`` every drone, ``drone`` one (or None)."""
        if query == "discover":
            return {"ok": True, "drones": self.snapshot()}
        record = self.fleet.get(drone_id or "")
        return {"ok": True, "drone": record.public(self.lost_after_s) if record else None}

    # -- persistence ---------------------------------------------------------------------------
    async def _persist_loop(self) -> None:
        while True:
            await asyncio.sleep(1.0)
            now = timestamp_s()
            self._dirty = {d for d in self._dirty if self.persists(d)}
            due = [
                d for d in self._dirty if now - self._persisted_at.get(d, 0.0) >= PERSIST_EVERY_S
            ]
            if due:
                await self._flush(due)

    async def _flush(self, drone_ids: list[str] | None = None) -> None:
        """Save the records of ``drone_ids`` (all the changed ones by default), a chunk of
        :data:`PERSIST_CHUNK` at a time: the records of a whole fleet heard at once fall due
        together, and dumping 1000 of them held the event loop 50 ms, which a REST request
        waited through (bench/ground_capacity.py: ``GET /api/v1/drones`` p99 73-101 ms)."""
        asked = list(self._dirty) if drone_ids is None else drone_ids
        self._dirty.difference_update(d for d in asked if d not in self.fleet)
        ids = [d for d in asked if d in self.fleet]
        for start in range(0, len(ids), PERSIST_CHUNK):
            chunk = ids[start : start + PERSIST_CHUNK]
            records = [self.fleet[d].model_dump(mode="json") for d in chunk]
            try:
                await self.state.save_drones(records)
            except Exception:  # a full disk must not stop the fleet from being tracked
                log.exception("could not save %d drone records", len(records))
                return
            now = timestamp_s()
            for d in chunk:
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
