"""The Fleet Inbox (issue 27): the fleet's stream read once for every ground service.

Telemetry (5 Hz) and heartbeats (every 5 s) are nearly all a ground receives: a thousand drones
send over 5,000 messages a second. Each ground service used to take them on a broker connection
of its own and decode and validate each again (the Drone Identifier, the Telemetry Analyzer's
connector, the live stream, the separation monitor, the Mission Planner), and one core was
saturated at about 90 drones. The inbox receives them once for the whole ground (as Skybrush's
server has one connection per network and a signal bus inside): each message is decoded and
validated once, as its shared model read leniently (messaging/inbound.py: fields a newer drone
adds are ignored), checked once to speak for the drone of its topic, and the typed model is
handed to every consumer in this process. What it drops is counted once
(:meth:`FleetInbox.dropped_counts`, the health's ``dropped_messages``: ``malformed heartbeat``,
``telemetry on another drone's topic``, ...). The consumers keep their own refusal rules (the
connector screens field ranges and timestamps).

Each channel has a connection of its own (:class:`Feed`: ``+/telemetry/out``,
``+/heartbeats/out``). On one, a ground that fell behind on telemetry read its heartbeats behind
the same backlog in the same TCP stream, and drones were declared lost for the ground's own delay
(bench/ground_capacity.py: 258 of 1000 on a host loaded 14 to 28); the event loop reads a packet
from each ready connection in turn, so heartbeats on their own never wait for telemetry.

A consumer is handed each message either **directly** — a plain function called at once, which
must be quick and never wait (the connector's buffer, the live stream's fan-out, the planner's
latest positions) — or through a **queue** of its own with its own worker task (the separation
monitor, the Drone Identifier: they publish), so a slow consumer never holds up another; a full
queue drops its oldest message, counted per consumer.

A ground service given no inbox (a test of that service alone) opens one of its own.

**Over NATS** (``over_nats``, ``--fleet-over-nats``): with a NATS broker, both feeds read the
stream on the broker's NATS client port (messaging/nats_link.py) instead of MQTT, at about a
third of the CPU a message; everything after the read is the same.

**Partitioned** (ground/partition.py: replicas sharing the fleet by drone), the telemetry feed
holds at the broker only this replica's own drones' topics (:meth:`FleetInbox.take_only`), and the
other replicas' drones come as **peer** messages: their latest telemetry, a few times a second, in
the pictures the replicas exchange (ground/picture_share.py). Each consumer says which it takes
(``takes``): ``all`` (the live stream, the Identifier, the planner: the whole fleet), ``own`` (the
telemetry connector: each message stored by its owner; the separation monitor's comparisons) or
``peers``.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections import Counter, deque
from collections.abc import Awaitable, Callable
from typing import Any, Generic, Literal, TypeVar

from dronefleet.messaging.client import QOS_STREAM, BrokerClient
from dronefleet.messaging.codec import MessageError
from dronefleet.messaging.inbound import parse_message, speaks_for_itself
from dronefleet.messaging.log_throttle import LogThrottle
from dronefleet.messaging.nats_link import NatsLink
from dronefleet.messaging.status import Heartbeat, Telemetry
from dronefleet.messaging.topics import Channel, Direction, any_drone, topic

log = logging.getLogger(__name__)
_throttle = LogThrottle(log)  # one line per kind per 10 s: junk on the broker must not flood it

M = TypeVar("M", Heartbeat, Telemetry)
#: Which messages a consumer is handed: its replica's own drones', the other replicas' (peer
#: pictures, partitioned only) or both. Unpartitioned, every message is an own one.
Takes = Literal["all", "own", "peers"]

#: The option that reads the fleet's stream over NATS (messaging/nats_link.py).
OVER_NATS = "--fleet-over-nats"
#: Messages waiting per queued consumer; beyond it the oldest is dropped (counted).
QUEUE_LIMIT = 5_000
#: A queued consumer's worker lets the loop run other work after this many messages in a row.
BATCH = 64


class _Queue(Generic[M]):
    """One queued consumer: its bounded queue and its worker."""

    def __init__(
        self,
        kind: str,
        name: str,
        handler: Callable[[M], Awaitable[None]],
        limit: int,
        takes: Takes,
    ) -> None:
        self.kind, self.name, self.limit, self.takes = kind, name, limit, takes
        self.handler: Callable[[M], Awaitable[None]] = handler
        self.items: deque[M] = deque()
        self.dropped = 0  # pushed out of a full queue
        self._ready = asyncio.Event()
        self.task = asyncio.create_task(self._work(), name=f"inbox:{kind}:{name}")

    def put(self, message: M) -> None:
        if len(self.items) >= self.limit:
            self.items.popleft()
            self.dropped += 1
            _throttle.log(logging.WARNING, f"full:{self.kind}:{self.name}",
                          "the %s is behind on %s: its oldest message dropped", self.name,
                          self.kind)  # fmt: skip
        self.items.append(message)
        self._ready.set()

    async def _work(self) -> None:
        while True:
            await self._ready.wait()
            self._ready.clear()
            done = 0
            while self.items:
                message = self.items.popleft()
                try:
                    await self.handler(message)
                except Exception:
                    _throttle.log(logging.ERROR, f"fail:{self.kind}:{self.name}",
                                  "the %s failed on a %s of %s; dropped", self.name, self.kind,
                                  message.drone_id, exc=True)  # fmt: skip
                done += 1
                if done % BATCH == 0:
                    await asyncio.sleep(0)  # a backlog does not keep the loop to itself

    async def stop(self) -> None:
        self.task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await self.task


class Feed(Generic[M]):
    """One channel of the fleet's stream: its connection, its model and who is handed each
    message."""

    def __init__(
        self,
        broker_url: Any,
        client_id: str,
        channel: Channel,
        kind: str,
        model: type[M],
        over_nats: str | None = None,
    ) -> None:
        name = f"{client_id}-{channel}"
        self.client: BrokerClient | NatsLink = (
            BrokerClient(broker_url, name)
            if over_nats is None
            else NatsLink(over_nats, broker_url, name=name, option=OVER_NATS)
        )
        self.channel, self.kind = channel, kind
        self.model: type[M] = model
        self._direct: list[tuple[str, Callable[[M], Any], Takes]] = []
        self._queues: list[_Queue[M]] = []
        self.received = 0  # messages read and handed on

    def direct(self, name: str, handler: Callable[[M], Any], *, takes: Takes = "all") -> None:
        """Call ``handler(message)`` at once for every message: it must be quick, never wait."""
        self._direct.append((name, handler, takes))

    def queued(
        self,
        name: str,
        handler: Callable[[M], Awaitable[None]],
        *,
        limit: int = QUEUE_LIMIT,
        takes: Takes = "all",
    ) -> None:
        """Await ``handler(message)`` for every message, in order, on a worker of its own."""
        self._queues.append(_Queue(self.kind, name, handler, limit, takes))

    async def detach(self, name: str) -> None:
        """Hand ``name`` nothing more (its queue, if any, is dropped)."""
        self._direct = [(n, h, t) for n, h, t in self._direct if n != name]
        leaving = [q for q in self._queues if q.name == name]
        self._queues = [q for q in self._queues if q.name != name]
        for queue in leaving:
            await queue.stop()

    def hand(self, message: M, *, peer: bool = False) -> None:
        """``message`` to its consumers: an own one (read from the broker) or, ``peer``, one of
        another replica's drones (its picture)."""
        skip = "own" if peer else "peers"
        if not peer:
            self.received += 1
        for name, handler, takes in self._direct:
            if takes == skip:
                continue
            try:
                handler(message)
            except Exception:
                _throttle.log(logging.ERROR, f"fail:{self.kind}:{name}",
                              "the %s failed on a %s of %s; dropped", name, self.kind,
                              message.drone_id, exc=True)  # fmt: skip
        for queue in self._queues:
            if queue.takes != skip:
                queue.put(message)

    def behind(self) -> dict[str, int]:
        """Messages dropped from full queues, by consumer (and by a NATS link, behind)."""
        counts = {
            f"{self.kind} queue full ({q.name})": q.dropped for q in self._queues if q.dropped
        }
        if isinstance(self.client, NatsLink) and self.client.dropped:
            counts[f"{self.kind} dropped by the NATS link (behind)"] = self.client.dropped
        return counts

    async def close(self) -> None:
        for queue in self._queues:
            await queue.stop()
        self._queues, self._direct = [], []


class FleetInbox:
    """``await FleetInbox(url, client_id=...).start()``; consumers attach to :attr:`telemetry`
    and :attr:`heartbeats` (``direct`` or ``queued``) before or after it starts.
    ``partitioned``: no drone's telemetry is taken until :meth:`take_only` names it."""

    def __init__(
        self,
        broker_url: Any,
        *,
        client_id: str,
        partitioned: bool = False,
        over_nats: str | None = None,
    ) -> None:
        self.partitioned = partitioned
        self.telemetry: Feed[Telemetry] = Feed(
            broker_url, client_id, Channel.TELEMETRY, "telemetry", Telemetry, over_nats
        )
        self.heartbeats: Feed[Heartbeat] = Feed(
            broker_url, client_id, Channel.HEARTBEATS, "heartbeat", Heartbeat, over_nats
        )
        #: Messages refused, by why (the health's ``dropped_messages``).
        self.dropped: Counter[str] = Counter()
        self._subscribed = False

    @property
    def feeds(self) -> tuple[Feed[Telemetry], Feed[Heartbeat]]:
        return self.telemetry, self.heartbeats

    async def start(self) -> FleetInbox:
        if not self._subscribed:
            self._subscribed = True
            await self._subscribe(self.telemetry)
            await self._subscribe(self.heartbeats)
        for feed in self.feeds:
            await feed.client.start()
        return self

    async def stop(self) -> None:
        for feed in self.feeds:
            await feed.client.stop()
            await feed.close()

    async def _subscribe(self, feed: Feed[M]) -> None:
        async def receive(topic_name: str, payload: bytes) -> None:
            self.receive(feed, topic_name, payload)

        await feed.client.subscribe(any_drone(feed.channel), receive, qos=QOS_STREAM)
        if self.partitioned and feed is self.telemetry:
            await self.take_only(set())

    async def take_only(self, drone_ids: set[str]) -> None:
        """Partitioned: take the telemetry of ``drone_ids`` (this replica's own) and no other."""
        filters = {topic(d, Channel.TELEMETRY, Direction.OUT) for d in drone_ids}
        await self.telemetry.client.narrow(any_drone(Channel.TELEMETRY), filters)

    def receive(self, feed: Feed[M], topic_name: str, payload: bytes) -> None:
        """A message as the broker delivers it: read once, handed to ``feed``'s consumers."""
        message = self.read(feed, topic_name, payload)
        if message is not None:
            feed.hand(message)

    def read(self, feed: Feed[M], topic_name: str, payload: bytes) -> M | None:
        """The message as ``feed``'s model, or None (counted and logged) if it is malformed or
        speaks for another drone than its topic's."""
        try:
            message = parse_message(feed.model, payload)
        except MessageError as exc:
            self.dropped[f"malformed {feed.kind}"] += 1
            _throttle.log(logging.WARNING, f"malformed:{feed.kind}", "dropping %s on %s: %s",
                          feed.kind, topic_name, exc)  # fmt: skip
            return None
        try:
            speaks_for_itself(topic_name, message.drone_id)
        except MessageError:
            self.dropped[f"{feed.kind} on another drone's topic"] += 1
            _throttle.log(logging.WARNING, f"forged:{feed.kind}", "dropping %s of %s sent on %s",
                          feed.kind, message.drone_id, topic_name)  # fmt: skip
            return None
        return message

    def dropped_counts(self) -> dict[str, int]:
        """Every message refused or not read in time, by why."""
        return {**self.dropped, **self.telemetry.behind(), **self.heartbeats.behind()}
