"""The one broker client (aiomqtt) every component uses (seed: the Broker Client submodule).

It reconnects by itself (connection.py) and re-subscribes what was subscribed. Each subscription
has its own ordered queue and worker (subscriptions.py), so a slow handler never holds up another
topic. A handler that raises is logged and the message dropped: a component never dies on input.
Publishing while the broker is away waits for it to come back (QoS 1 messages are never silently
dropped), unless the caller says the message is disposable (heartbeats, telemetry; publishing.py).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections import deque
from typing import Any, Unpack

import aiomqtt
from paho.mqtt.client import topic_matches_sub

from dronefleet.messaging.acks import AckTicket
from dronefleet.messaging.connection import BrokerUnavailable, LinkOptions
from dronefleet.messaging.local_bus import SessionClosed
from dronefleet.messaging.mqtt_link import subscribed
from dronefleet.messaging.publishing import QOS_COMMAND, QOS_STREAM, Publishing
from dronefleet.messaging.subscriptions import QUEUE_LIMIT, Handler, Subscription, offer, work
from dronefleet.messaging.topic_routes import TopicRoutes, broker_filters, covers
from dronefleet.messaging.url import BrokerUrl

log = logging.getLogger(__name__)

__all__ = [
    "QOS_COMMAND",
    "QOS_STREAM",
    "BrokerClient",
    "BrokerUnavailable",
    "covers",
]


#: Topic filters sent in one SUBSCRIBE or UNSUBSCRIBE packet at most.
FILTERS_PER_PACKET = 100
#: A filter the broker refused is asked for again after this many seconds, at most
#: :data:`REFUSED_TRIES` times on a link: a NATS node refuses a QoS 1 filter whose JetStream
#: consumer it could not make in 5 s (its leader lost with a node, not elected again yet). It
#: was taken as subscribed, and the drone heard nothing on it until its next link. A filter no
#: right allows is refused each time: it is said in the log, and the link works on without it.
REFUSED_AGAIN_S = 1.0
REFUSED_TRIES = 10


class BrokerClient(Publishing):
    """A persistent, self-healing connection to one MQTT broker."""

    def __init__(
        self,
        url: str | BrokerUrl,
        client_id: str,
        *,
        retired: tuple[str, ...] = (),
        **options: Unpack[LinkOptions],
    ) -> None:
        if retired and not options.get("persistent_session"):
            raise ValueError("retired filters apply to a persistent session only")
        super().__init__(url, client_id, **options)
        #: Filters an earlier version of this component subscribed in its persistent session and
        #: this one does not. A resumed session keeps its subscriptions at the broker, which
        #: would send their messages for ever (the Mission Planner's heartbeats, 2,000 a second
        #: at 10,000 drones: issue 27), so they are unsubscribed on every link.
        self._retired = retired
        self._subs: list[Subscription] = []
        self._routes = TopicRoutes()
        self._at_broker: dict[str, int] = {}  # filter -> QoS subscribed on this connection
        self._sync_lock = asyncio.Lock()
        self._refusals = 0  # rounds of filters refused on this link (SUBACK 0x80)
        self._again: asyncio.Task[None] | None = None  # the next round after a refusal
        #: A persistent session's messages that came before any subscription matched them.
        self._unclaimed: deque[tuple[str, bytes, int, int, Any]] = deque()
        #: The QoS 1 messages of a persistent session still with a handler, by link and packet
        #: id. NATS sends a message not acknowledged within its ack_wait (2 s) again on the same
        #: link, with the same id: a copy of one still waiting here is not queued again. Queued,
        #: a backlog over 2 s doubled every 2 s, the full queues dropped the originals (acking
        #: them), and progress reports were lost (CI: a mission on a cluster under load).
        self._held: dict[tuple[int, int], AckTicket] = {}
        self.redelivered = 0  # such copies, not queued

    # -- lifecycle ---------------------------------------------------------------------------
    async def start(self, *, timeout_s: float | None = 10.0) -> BrokerClient:
        """Connect (retrying in the background) and wait up to ``timeout_s`` for the first link."""
        if self._runner is None:
            self._stopping = False
            for sub in self._subs:  # started again after a stop: its subscriptions work again
                if sub.worker is None:
                    sub.worker = asyncio.create_task(work(sub), name=f"sub:{sub.pattern}")
            self._runner = asyncio.create_task(self._run(), name=f"mqtt:{self.client_id}")
        if timeout_s is not None:
            try:
                async with asyncio.timeout(timeout_s):
                    await self._connected.wait()
            except TimeoutError as exc:
                raise BrokerUnavailable(
                    f"broker {self.url} not reachable within {timeout_s:g} s"
                ) from exc
        return self

    async def stop(self) -> None:
        self._stopping = True
        if self._runner is not None:
            # aiomqtt's clean disconnect waits for the broker without a limit: a broker that does
            # not answer must not hang us, so a second cancel interrupts that wait.
            for _ in range(3):
                self._runner.cancel()
                done, _ = await asyncio.wait({self._runner}, timeout=2.0)
                if done:
                    break
            with contextlib.suppress(asyncio.CancelledError, Exception):
                if self._runner.done():
                    self._runner.result()
            self._runner = None
        if self._again is not None:
            self._again.cancel()
            self._again = None
        for sub in self._subs:
            if sub.worker is not None:
                sub.worker.cancel()
                with contextlib.suppress(asyncio.CancelledError, Exception):
                    await sub.worker
                sub.worker = None
        self._connected.clear()

    async def __aenter__(self) -> BrokerClient:
        return await self.start()

    async def __aexit__(self, *exc: object) -> None:
        await self.stop()

    # -- subscribe ---------------------------------------------------------------------------
    async def subscribe(self, pattern: str, handler: Handler, *, qos: int = QOS_COMMAND) -> None:
        """Call ``handler(topic, payload)`` for each message matching ``pattern``, in order.
        ``qos`` is held at the broker by a persistent session; a clean one holds QoS 0
        (:meth:`_held_filters`)."""
        if pattern in self._retired:
            raise ValueError(f"{pattern!r} is a retired filter of this client: it is unsubscribed")
        sub = Subscription(pattern, handler, qos)
        self._routes.add(sub)
        sub.worker = asyncio.create_task(work(sub), name=f"sub:{pattern}")
        self._subs.append(sub)
        if self._unclaimed:
            waiting, self._unclaimed = self._unclaimed, deque()
            for topic_name, payload, mid, msg_qos, link in waiting:
                if topic_matches_sub(pattern, topic_name):
                    self._dispatch(topic_name, payload, mid, msg_qos, link)
                else:
                    self._unclaimed.append((topic_name, payload, mid, msg_qos, link))
        if self._client is not None and self.connected:
            with contextlib.suppress(aiomqtt.MqttError, SessionClosed):
                await self._sync_filters(self._client)

    async def narrow(self, pattern: str, filters: set[str]) -> None:
        """Hold only ``filters`` (each within ``pattern``) at the broker for the subscription
        ``pattern``: a ground replica takes its own drones' telemetry (ground/partition.py).
        Messages are still routed by ``pattern``; an empty set holds nothing."""
        outside = [one for one in filters if not covers(pattern, one)]
        if outside:
            raise ValueError(f"{outside[0]!r} is not within {pattern!r}")
        for sub in self._subs:
            if sub.pattern == pattern:
                sub.at_broker = frozenset(filters)
        if self._client is not None and self.connected:
            with contextlib.suppress(aiomqtt.MqttError, SessionClosed):
                await self._sync_filters(self._client)

    async def _link_up(self, client: Any) -> None:
        """On a new link: nothing is subscribed there yet; subscribe what is wanted."""
        self._at_broker = {}
        self._refusals = 0
        if self._retired:
            await self._unsubscribe(client, list(self._retired))
        await self._sync_filters(client)

    async def _sync_filters(self, client: Any) -> None:
        """Subscribe what :func:`broker_filters` wants at the broker and is not there yet (or at
        a lower QoS), then unsubscribe what it no longer wants (the wider filter is in place
        first). Filters go :data:`FILTERS_PER_PACKET` to a SUBSCRIBE or UNSUBSCRIBE: a ground
        replica's share of a fleet (ground/partition.py) is a filter a drone, and a replica
        joining or leaving moves hundreds, which one round trip each made seconds on a loaded
        host."""
        async with self._sync_lock:
            while (target := self._held_filters()) != self._at_broker:
                wanted = [(p, q) for p, q in target.items() if self._at_broker.get(p, -1) < q]
                refused = []
                for start in range(0, len(wanted), FILTERS_PER_PACKET):
                    chunk = wanted[start : start + FILTERS_PER_PACKET]
                    answers = await subscribed(client, chunk)
                    for (pattern, qos), taken in zip(chunk, answers, strict=True):
                        if taken:
                            self._at_broker[pattern] = qos
                        else:
                            refused.append(pattern)
                gone = [p for p in self._at_broker if p not in target]
                await self._unsubscribe(client, gone)
                for pattern in gone:
                    del self._at_broker[pattern]
                if refused:
                    self._ask_again(client, refused)
                    return

    def _held_filters(self) -> dict[str, int]:
        """The filters to hold at the broker, and at which QoS: a clean session holds them at
        QoS 0. Its messages end with its link, so QoS 1 delivers nothing more to it than QoS 0
        over the same TCP link (MQTT 3.1.1 §4.4: messages are sent again only to a session that
        persists), and on NATS it cost a JetStream consumer per filter, a Raft group on
        ``stream_replicas`` nodes: each link deleted the last link's and made new ones, and
        after a node's loss a drone was cut off until every one of them had a leader again, up
        to 35 s on a loaded host (docs/resilience.md). What a clean session publishes keeps
        its QoS."""
        held = broker_filters(self._subs)
        return held if self.persistent_session else dict.fromkeys(held, 0)

    def _ask_again(self, client: Any, refused: list[str]) -> None:
        """Sync the filters again in :data:`REFUSED_AGAIN_S`, in the background (a link is not
        held up by a filter the broker refuses), at most :data:`REFUSED_TRIES` times a link."""
        self._refusals += 1
        if self._refusals >= REFUSED_TRIES:
            log.warning(
                "%s: the broker refused %s %d times; asked again on the next subscription or link",
                self.client_id, refused, self._refusals,
            )  # fmt: skip
            return
        if self._again is None or self._again.done():
            self._again = asyncio.create_task(self._sync_again(client), name="mqtt:subscribe-again")

    async def _sync_again(self, client: Any) -> None:
        await asyncio.sleep(REFUSED_AGAIN_S)
        self._again = None  # a refusal now schedules the next round
        if self._client is client and self.connected:
            with contextlib.suppress(aiomqtt.MqttError, SessionClosed):
                await self._sync_filters(client)

    @staticmethod
    async def _unsubscribe(client: Any, filters: list[str]) -> None:
        for start in range(0, len(filters), FILTERS_PER_PACKET):
            dropped = filters[start : start + FILTERS_PER_PACKET]
            if isinstance(client, aiomqtt.Client) and len(dropped) > 1:
                await client.unsubscribe(dropped)
            else:
                for pattern in dropped:
                    await client.unsubscribe(pattern)

    # -- incoming messages -------------------------------------------------------------------
    def _release(self, key: tuple[int, int]) -> None:
        self._held.pop(key, None)

    def _dispatch(
        self, topic_name: str, payload: bytes, mid: int = 0, qos: int = 0, link: Any = None
    ) -> None:
        link = link if link is not None else self._paho
        subs = self._routes.of(topic_name)
        if not subs and self.persistent_session and qos > 0:
            # A resumed session's messages come with the CONNACK, maybe before the component
            # has subscribed again: kept, unacknowledged, for the subscription that claims them.
            if len(self._unclaimed) >= QUEUE_LIMIT:
                self._unclaimed.popleft()
            self._unclaimed.append((topic_name, payload, mid, qos, link))
            return
        ticket = None
        if self.persistent_session and qos > 0 and link is not None:
            key = (id(link), mid)
            held = self._held.get(key)
            if held is not None and held.open:
                self.redelivered += 1
                return
            ticket = AckTicket(link, mid, qos, pending=len(subs), acked=lambda: self._release(key))
            if ticket.open:
                self._held[key] = ticket
        for sub in subs:
            offer(sub, topic_name, payload, ticket, self.client_id)
