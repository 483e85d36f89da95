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

The link is messaging/nats_link.py's (``nats-py``; the ground's broker user, never anonymous;
a server that does not carry what the MQTT broker carries is refused at start). Each message is
read as the inbox reads it (the same model, leniently; the same check that it speaks for its
topic's drone), and one that fails is counted (:attr:`dropped`) and dropped.
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Callable
from typing import Any

from dronefleet.messaging.codec import MessageError
from dronefleet.messaging.inbound import parse_message, speaks_for_itself
from dronefleet.messaging.log_throttle import LogThrottle
from dronefleet.messaging.nats_config import nats_subject
from dronefleet.messaging.nats_link import NatsLink, NatsNotUsable
from dronefleet.messaging.status import Telemetry
from dronefleet.messaging.topics import Channel, any_drone
from dronefleet.messaging.url import BrokerUrl

log = logging.getLogger(__name__)
_throttle = LogThrottle(log)

#: The queue group every replica's ingestion joins.
QUEUE_GROUP = "ground-telemetry"
#: Every drone's telemetry, as a NATS subject: ``*.telemetry.out``.
SUBJECT = nats_subject(any_drone(Channel.TELEMETRY))[0]
#: The option, named in its refusals (messaging/nats_link.py's ``check_usable``, ...).
OPTION = "--share-ingestion"
#: The option's refusals (messaging/nats_link.py's, named for it).
IngestionNotShared = NatsNotUsable


class SharedIngest:
    """``await SharedIngest(nats_url, broker_url, take=connector.take).start()``: ``take`` gets
    this replica's share of the fleet's telemetry, each message read and checked."""

    def __init__(
        self, nats_url: str, broker_url: BrokerUrl, *, take: Callable[[Telemetry], Any], name: str
    ) -> None:
        self.link = NatsLink(nats_url, broker_url, name=name, option=OPTION)
        self.take = take
        self.name = name
        self.received = 0  # messages taken and handed on
        #: Messages refused, by why (the same reasons as the inbox's).
        self.dropped: Counter[str] = Counter()

    @property
    def connected(self) -> bool:
        return self.link.connected

    async def start(self) -> SharedIngest:
        async def take(topic_name: str, payload: bytes) -> None:
            self.receive(topic_name, payload)

        await self.link.subscribe(any_drone(Channel.TELEMETRY), take, queue=QUEUE_GROUP)
        await self.link.start()
        return self

    async def stop(self) -> None:
        await self.link.stop()

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
