"""A ground's link to its broker over NATS's own protocol, beside its MQTT links (issue 27).

When the broker is NATS (the embedded default, messaging/nats_broker.py, or a cluster), every
MQTT topic is also a NATS subject (``QUAD_1/telemetry/out`` is ``QUAD_1.telemetry.out``,
messaging/nats_config.py), and a QoS 0 MQTT publish is a plain NATS message on it. A ground can
then read the fleet's stream on the NATS client port, which costs it far less per message than
MQTT does: 6.5-8.3 us of CPU a message with nats-py against 20-24 us through paho and our
subscriptions (10,000 telemetry messages a second, one wildcard subscription, a handler that does
nothing; 11.2 us with a subscription a drone, as a partitioned replica holds them). Two uses:

- the Fleet Inbox reads its telemetry and heartbeats here (``--fleet-over-nats``,
  ground/inbox.py);
- shared ingestion takes a share of the telemetry in a queue group
  (``--share-ingestion``, ground/telemetry/shared_ingest.py).

The client is ``nats-py``, NATS's official asyncio client: it reconnects by itself, to another
node of a cluster too, and subscribes again what was subscribed. The link logs in as the
ground's broker user with the same password, never anonymously; the broker's rules
(messaging/broker_acl.py) apply on the NATS port as on the MQTT one. At start it refuses a
server that does not let the user in, or that does not carry what is published on the MQTT
broker (a NATS beside a Mosquitto): it publishes a probe through the MQTT broker and waits for
it here. The options that use it are refused with a ``local://`` bus.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import secrets
from collections.abc import Awaitable, Callable

import nats
from nats.aio.client import Client as NatsClient
from nats.aio.msg import Msg
from nats.aio.subscription import Subscription

from dronefleet.errors import InvalidInput
from dronefleet.messaging.client import QOS_STREAM, BrokerClient
from dronefleet.messaging.log_throttle import LogThrottle
from dronefleet.messaging.nats_config import mqtt_topic, nats_subject
from dronefleet.messaging.topics import ground
from dronefleet.messaging.url import BrokerUrl

log = logging.getLogger(__name__)
_throttle = LogThrottle(log)

#: Bounds on reaching the NATS server, and on the probe through the MQTT broker.
CONNECT_TIMEOUT_S = 5.0
PROBE_TIMEOUT_S = 10.0
FLUSH_TIMEOUT_S = 5  # nats-py takes whole seconds
_PROBE_EVERY_S = 0.2
#: Messages a subscription holds for its handler before nats-py drops them (a slow consumer).
PENDING_MSGS = 100_000

Handler = Callable[[str, bytes], Awaitable[None]]


class NatsNotUsable(InvalidInput):
    """An option that reads over NATS does not apply: not a NATS broker, no credentials, ..."""


def nats_servers(url: str, option: str) -> list[str]:
    """``nats://host:port[,host:port...]`` as nats-py's list of servers (``option`` names the
    command-line option in the reason when it is not one)."""
    scheme, sep, rest = url.partition("://")
    if scheme == "tls":
        raise NatsNotUsable(f"{option} over TLS (tls://) is not supported yet")
    if not sep or scheme != "nats" or not rest:
        raise NatsNotUsable(
            f"{option} wants the NATS client address of the broker, "
            f"nats://HOST:PORT[,HOST:PORT...] (NATS's port, 4222 by default), not {url!r}"
        )
    return [f"nats://{node.strip()}" for node in rest.split(",") if node.strip()]


def check_usable(broker_url: BrokerUrl, option: str) -> None:
    """Refuse, before anything starts, a broker ``option`` cannot apply to."""
    if broker_url.local:
        raise NatsNotUsable(
            f"{option} needs a NATS broker; {broker_url} is an in-process bus: leave the option out"
        )
    if not broker_url.username or not broker_url.password:
        raise NatsNotUsable(
            f"{option} logs in to NATS as the ground's broker user, never anonymously: give "
            "--broker mqtt://USER@HOST:PORT and its password file"
        )


def _refused(exc: Exception | None) -> bool:
    """Whether ``exc`` is the server's refusal of the ground's user (the most telling reason)."""
    return exc is not None and "authorization" in str(exc).lower()


class NatsLink:
    """``await NatsLink(nats_url, broker_url, name=..., option=...).start()``; MQTT filters
    subscribed with :meth:`subscribe` (before or after the start) are handed their messages as
    ``handler(mqtt_topic, payload)``."""

    def __init__(
        self, nats_url: str, broker_url: str | BrokerUrl, *, name: str, option: str
    ) -> None:
        if not isinstance(broker_url, BrokerUrl):
            broker_url = BrokerUrl.parse(broker_url)
        check_usable(broker_url, option)
        self.servers = nats_servers(nats_url, option)
        self.broker_url, self.name, self.option = broker_url, name, option
        self._nc: NatsClient | None = None
        #: What is wanted: the MQTT filters of each pattern subscribed, its handler and group.
        self._wanted: dict[str, tuple[frozenset[str], Handler, str]] = {}
        self._held: dict[str, Subscription] = {}  # NATS subject -> its subscription
        #: The link's last error, for a refusal's reason: a refusal by the server outranks what
        #: came after it (NATS closes the socket on an authorization violation, so the next try
        #: may only see a reset connection).
        self._last_error: Exception | None = None
        self._sync_lock = asyncio.Lock()
        #: Links made (1 + reconnects): what was subscribed is subscribed again on each, so
        #: silence counts afresh from there (the Drone Identifier watches it).
        self.connections = 0
        #: Messages nats-py dropped because a subscription's handler fell behind by
        #: :data:`PENDING_MSGS` (a slow consumer): counted, as a full queue's are.
        self.dropped = 0

    @property
    def connected(self) -> bool:
        return self._nc is not None and self._nc.is_connected

    async def subscribe(
        self, pattern: str, handler: Handler, *, qos: int = QOS_STREAM, queue: str = ""
    ) -> None:
        """Hand ``handler`` the messages on the MQTT filter ``pattern`` (QoS 0 only: a NATS
        subscriber gets the plain messages); ``queue``: as one of that NATS queue group."""
        if qos != QOS_STREAM:
            raise ValueError("a NATS link takes the QoS 0 stream only")
        self._wanted[pattern] = (frozenset({pattern}), handler, queue)
        await self._sync()

    async def narrow(self, pattern: str, filters: set[str]) -> None:
        """Hold only ``filters`` (each within ``pattern``) for the subscription ``pattern``, as
        :meth:`BrokerClient.narrow`: an empty set holds nothing."""
        _, handler, queue = self._wanted[pattern]
        self._wanted[pattern] = (frozenset(filters), handler, queue)
        await self._sync()

    async def start(self) -> NatsLink:
        try:
            self._nc = await nats.connect(
                servers=self.servers,
                user=self.broker_url.username,
                password=self.broker_url.password,
                name=self.name,
                connect_timeout=CONNECT_TIMEOUT_S,
                # At start, each server tried twice, then refused (with -1 nats-py would try
                # forever, never saying that nothing answers in NATS)...
                max_reconnect_attempts=1,
                allow_reconnect=True,
                error_cb=self._error,
                reconnected_cb=self._reconnected,
            )
            self.connections += 1
            # ... and once in, forever: the broker comes back, or another node of the cluster.
            self._nc.options["max_reconnect_attempts"] = -1
        except Exception as exc:
            why = self._last_error or exc
            raise NatsNotUsable(
                f"{self.option}: no NATS server at {', '.join(self.servers)} let the ground "
                f"user {self.broker_url.username} in ({str(why) or type(why).__name__}); the "
                "option needs the broker to be NATS (Mosquitto and RabbitMQ have no NATS "
                "port), its NATS client port and the ground's broker password"
            ) from exc
        try:
            await self._probe()
            await self._sync()
        except BaseException:
            await self.stop()
            raise
        return self

    async def stop(self) -> None:
        nc, self._nc = self._nc, None
        self._held = {}
        if nc is not None and not nc.is_closed:
            with contextlib.suppress(Exception):
                await nc.close()

    async def _sync(self) -> None:
        """Subscribe at the server what is wanted and is not held, and drop what is held and no
        longer wanted (nats-py subscribes again by itself after a reconnect)."""
        if self._nc is None:
            return
        async with self._sync_lock:
            want: dict[str, tuple[Handler, str]] = {}
            for filters, handler, queue in self._wanted.values():
                for mqtt in filters:
                    want.update(dict.fromkeys(nats_subject(mqtt), (handler, queue)))
            for subject in [s for s in self._held if s not in want]:
                with contextlib.suppress(Exception):
                    await self._held.pop(subject).unsubscribe()
            for subject, (handler, queue) in want.items():
                if subject not in self._held:
                    self._held[subject] = await self._nc.subscribe(
                        subject, queue=queue, cb=_delivering(handler),
                        pending_msgs_limit=PENDING_MSGS,
                    )  # fmt: skip
            await self._nc.flush(timeout=FLUSH_TIMEOUT_S)  # in place at the server

    async def _probe(self) -> None:
        """Refuse a NATS server that does not carry what is published on the MQTT broker."""
        assert self._nc is not None
        topic = ground("nats-probe", secrets.token_hex(6))
        heard = asyncio.Event()

        async def on_probe(_msg: Msg) -> None:
            heard.set()

        sub = await self._nc.subscribe(nats_subject(topic)[0], cb=on_probe)
        await self._nc.flush(timeout=FLUSH_TIMEOUT_S)
        mqtt = BrokerClient(self.broker_url, f"{self.name}-probe")
        try:
            await mqtt.start()
            async with asyncio.timeout(PROBE_TIMEOUT_S):
                while not heard.is_set():
                    await mqtt.publish(topic, b"{}", qos=QOS_STREAM, disposable=True)
                    with contextlib.suppress(TimeoutError):
                        async with asyncio.timeout(_PROBE_EVERY_S):
                            await heard.wait()
        except TimeoutError:
            raise NatsNotUsable(
                f"{self.option}: the NATS server at {', '.join(self.servers)} does not carry "
                f"what is published on the broker {self.broker_url}: --broker must be that NATS "
                "server's MQTT listener (Mosquitto and RabbitMQ have no NATS port)"
            ) from None
        finally:
            await mqtt.stop()
            await sub.unsubscribe()

    async def _reconnected(self) -> None:
        self.connections += 1
        log.info("%s: NATS link made again (%s)", self.name, self._nc and self._nc.connected_url)

    async def _error(self, exc: Exception) -> None:
        if isinstance(exc, nats.errors.SlowConsumerError):
            self.dropped += 1
        elif not _refused(self._last_error):
            self._last_error = exc
        _throttle.log(logging.WARNING, f"nats:{self.name}", "%s, NATS link: %s", self.name,
                      str(exc) or type(exc).__name__)  # fmt: skip


def _delivering(handler: Handler) -> Callable[[Msg], Awaitable[None]]:
    async def deliver(msg: Msg) -> None:
        await handler(mqtt_topic(msg.subject), msg.data)

    return deliver
