"""Telemetry ingestion shared among ground replicas (issue 27): each message stored by one.

Every replica reads the whole fleet's stream through its Fleet Inbox (ground/inbox.py): its live
stream, separation monitor and Identifier need every message. Storing it is another matter: with
a shared telemetry store, N replicas each storing everything is N times the work for one copy.
MQTT 5's ``$share`` subscriptions would split it, but NATS's MQTT listener has none; NATS's own
protocol has **queue groups**: every subscriber of ``*.telemetry.out`` in the group
``ground-telemetry`` gets a share of the messages and each message goes to exactly one of them
(a QoS 0 MQTT publish is a plain NATS message on the subject ``QUAD_1.telemetry.out``,
messaging/nats_config.py). A replica that joins takes a share at once; one that dies (its
connection drops) gets nothing more. So, with ``--share-ingestion nats://HOST:4222``, the
replica's telemetry connector (ground/telemetry/connector.py) is fed from here instead of from
the inbox.

The client is ``nats-py``, NATS's official asyncio client (queue groups, reconnection with the
subscription restored, a cluster's other nodes learnt from the server). It logs in as the
ground's broker user with the same password (``--broker`` and its password file): never
anonymous. Each message is read as the inbox reads it (the same model, leniently; the same check
that it speaks for its topic's drone), and one that fails is counted (:attr:`dropped`) and
dropped.

Only a NATS broker has queue groups: a ``local://`` bus is refused at once, and a server that
does not answer in NATS, or does not carry what the ground publishes on its MQTT broker (a NATS
beside a Mosquitto), is refused at start (:func:`SharedIngest.start` sends a probe through the
MQTT broker and waits for it on the NATS side).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import secrets
from collections import Counter
from collections.abc import Callable
from typing import Any

import nats
from nats.aio.client import Client as NatsClient
from nats.aio.msg import Msg

from dronefleet.errors import InvalidInput
from dronefleet.messaging.client import QOS_STREAM, BrokerClient
from dronefleet.messaging.codec import MessageError
from dronefleet.messaging.inbound import parse_message, speaks_for_itself
from dronefleet.messaging.log_throttle import LogThrottle
from dronefleet.messaging.nats_config import mqtt_topic, nats_subject
from dronefleet.messaging.status import Telemetry
from dronefleet.messaging.topics import Channel, any_drone, ground
from dronefleet.messaging.url import BrokerUrl

log = logging.getLogger(__name__)
_throttle = LogThrottle(log)

#: The queue group every replica's ingestion joins.
QUEUE_GROUP = "ground-telemetry"
#: Every drone's telemetry, as a NATS subject: ``*.telemetry.out``.
SUBJECT = nats_subject(any_drone(Channel.TELEMETRY))[0]
#: Bounds on reaching the NATS server, and on the probe through the MQTT broker.
CONNECT_TIMEOUT_S = 5.0
PROBE_TIMEOUT_S = 10.0
FLUSH_TIMEOUT_S = 5  # nats-py takes whole seconds
_PROBE_EVERY_S = 0.2


class IngestionNotShared(InvalidInput):
    """``--share-ingestion`` does not apply: the broker is not NATS, or no credentials."""


def nats_servers(url: str) -> list[str]:
    """``nats://host:port[,host:port...]`` as nats-py's list of servers."""
    scheme, sep, rest = url.partition("://")
    if scheme == "tls":
        raise IngestionNotShared("--share-ingestion over TLS (tls://) is not supported yet")
    if not sep or scheme != "nats" or not rest:
        raise IngestionNotShared(
            f"--share-ingestion wants the NATS client address of the broker, "
            f"nats://HOST:PORT[,HOST:PORT...] (NATS's port, 4222 by default), not {url!r}"
        )
    return [f"nats://{node.strip()}" for node in rest.split(",") if node.strip()]


def check_shareable(broker_url: BrokerUrl) -> None:
    """Refuse, before anything starts, a broker the option cannot apply to."""
    if broker_url.local:
        raise IngestionNotShared(
            f"--share-ingestion needs a NATS broker (queue groups); {broker_url} is an "
            "in-process bus: leave the option out"
        )
    if not broker_url.username or not broker_url.password:
        raise IngestionNotShared(
            "--share-ingestion logs in to NATS as the ground's broker user, never "
            "anonymously: give --broker mqtt://USER@HOST:PORT and its password file"
        )


def _refused(exc: Exception | None) -> bool:
    """Whether ``exc`` is the server's refusal of the ground's user (the most telling reason)."""
    return exc is not None and "authorization" in str(exc).lower()


class SharedIngest:
    """``await SharedIngest(nats_url, broker_url, take=connector.take).start()``: ``take`` gets
    this replica's share of the fleet's telemetry, each message read and checked."""

    def __init__(
        self, nats_url: str, broker_url: BrokerUrl, *, take: Callable[[Telemetry], Any], name: str
    ) -> None:
        check_shareable(broker_url)
        self.servers = nats_servers(nats_url)
        self.broker_url = broker_url
        self.take = take
        self.name = name
        self.received = 0  # messages taken and handed on
        #: Messages refused, by why (the same reasons as the inbox's).
        self.dropped: Counter[str] = Counter()
        self._nc: NatsClient | None = None
        #: The NATS link's, for a refusal's reason: a refusal by the server outranks what came
        #: after it (NATS closes the socket on an authorization violation, so the next try may
        #: only see a reset connection).
        self._last_error: Exception | None = None

    @property
    def connected(self) -> bool:
        return self._nc is not None and self._nc.is_connected

    async def start(self) -> SharedIngest:
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
            )
            # ... and once in, forever: the broker comes back, or another node of the cluster.
            self._nc.options["max_reconnect_attempts"] = -1
        except Exception as exc:
            why = self._last_error or exc
            raise IngestionNotShared(
                f"--share-ingestion: no NATS server at {', '.join(self.servers)} let the ground "
                f"user {self.broker_url.username} in ({str(why) or type(why).__name__}); the "
                "option needs the broker to be NATS (Mosquitto and RabbitMQ have no queue "
                "groups), its NATS client port and the ground's broker password"
            ) from exc
        try:
            await self._probe()
            await self._nc.subscribe(SUBJECT, queue=QUEUE_GROUP, cb=self._on_message)
            await self._nc.flush(timeout=FLUSH_TIMEOUT_S)  # the subscription is in place
        except BaseException:
            await self.stop()
            raise
        return self

    async def _probe(self) -> None:
        """Refuse a NATS server that does not carry what is published on the MQTT broker."""
        assert self._nc is not None
        topic = ground("ingestion-probe", secrets.token_hex(6))
        subject = nats_subject(topic)[0]
        heard = asyncio.Event()

        async def on_probe(_msg: Msg) -> None:
            heard.set()

        sub = await self._nc.subscribe(subject, cb=on_probe)
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
            raise IngestionNotShared(
                f"--share-ingestion: the NATS server at {', '.join(self.servers)} does not "
                f"carry what is published on the broker {self.broker_url}: --broker must be "
                "that NATS server's MQTT listener (Mosquitto and RabbitMQ have no queue groups)"
            ) from None
        finally:
            await mqtt.stop()
            await sub.unsubscribe()

    async def _error(self, exc: Exception) -> None:
        if not _refused(self._last_error):
            self._last_error = exc
        _throttle.log(logging.WARNING, "nats", "shared ingestion, NATS link: %s",
                      str(exc) or type(exc).__name__)  # fmt: skip

    async def _on_message(self, msg: Msg) -> None:
        self.receive(mqtt_topic(msg.subject), msg.data)

    def receive(self, topic_name: str, payload: bytes) -> None:
        """One message of this replica's share: read, checked, handed to ``take``."""
        try:
            message = parse_message(Telemetry, payload)
        except MessageError as exc:
            self.dropped["malformed telemetry"] += 1
            _throttle.log(logging.WARNING, "malformed", "dropping telemetry on %s: %s",
                          topic_name, exc)  # fmt: skip
            return
        try:
            speaks_for_itself(topic_name, message.drone_id)
        except MessageError:
            self.dropped["telemetry on another drone's topic"] += 1
            _throttle.log(logging.WARNING, "forged", "dropping telemetry of %s sent on %s",
                          message.drone_id, topic_name)  # fmt: skip
            return
        self.received += 1
        try:
            self.take(message)
        except Exception:
            _throttle.log(logging.ERROR, "take", "storing telemetry of %s failed; dropped",
                          message.drone_id, exc=True)  # fmt: skip

    async def stop(self) -> None:
        nc, self._nc = self._nc, None
        if nc is not None and not nc.is_closed:
            with contextlib.suppress(Exception):
                await nc.close()
