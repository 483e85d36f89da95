"""The fleet's picture shared among partitioned ground replicas (issue 27, ground/partition.py).

Each replica takes only its own drones' telemetry from the broker. Every :data:`SHARE_S` it
publishes, in one message on ``ground/fleet-picture/<replica>`` (QoS 0, as telemetry), the latest
telemetry of each of its drones heard since the last: one message a replica, not five a drone,
so a replica reads the rest of the fleet at a small part of the cost of its stream. Each replica
hands the others' entries to its inbox's consumers as **peer** messages (ground/inbox.py): the
live stream, the Mission Planner, the Identifier and the separation monitor's neighbours see the
whole fleet, at the picture's rate for the drones of others.

A picture is read as any broker message: validated against the shared models (each entry a
:class:`~dronefleet.messaging.status.Telemetry`), and one that fails is counted and dropped
whole. Only ground users may publish ``ground/...`` (messaging/broker_acl.py); an entry is not
taken as a drone's own message either way, so it is never stored again.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections import Counter
from typing import Any

from pydantic import BaseModel, Field

from dronefleet.ground.inbox import FleetInbox
from dronefleet.messaging.client import QOS_STREAM, BrokerClient
from dronefleet.messaging.codec import MessageError
from dronefleet.messaging.inbound import parse_message
from dronefleet.messaging.log_throttle import LogThrottle
from dronefleet.messaging.status import Telemetry
from dronefleet.messaging.topics import ground

log = logging.getLogger(__name__)
_throttle = LogThrottle(log)

#: Seconds between a replica's pictures: the other replicas see its drones at 2 Hz (the
#: separation monitor moves a neighbour on by its velocity for up to 1 s).
SHARE_S = 0.5
#: Drones in one picture message at most (about 300 bytes each); more go in several. A picture
#: is read and handed on in one turn of the event loop, about 5 us a drone: 2,000 a message held
#: the loop 10 ms (heartbeats, REST and the stream waited behind it), 250 hold it about 1 ms.
PICTURE_DRONES = 250
TOPIC = ground("fleet-picture", "+")


class FleetPicture(BaseModel):
    """One replica's drones' latest telemetry."""

    replica: str = Field(min_length=1, max_length=200)
    telemetry: list[Telemetry] = Field(max_length=PICTURE_DRONES)


class PictureShare:
    """``await PictureShare(url, inbox, replica=..., client_id=...).start()``."""

    def __init__(
        self,
        broker_url: Any,
        inbox: FleetInbox,
        *,
        replica: str,
        client_id: str,
        share_s: float = SHARE_S,
    ) -> None:
        self.client = BrokerClient(broker_url, client_id)
        self.inbox, self.replica, self.share_s = inbox, replica, share_s
        self._latest: dict[str, Telemetry] = {}
        self.sent = 0  # entries published
        self.taken = 0  # other replicas' entries handed on
        self.dropped: Counter[str] = Counter()
        self._task: asyncio.Task[None] | None = None

    async def start(self) -> PictureShare:
        self.inbox.telemetry.direct("picture share", self._keep, takes="own")
        await self.client.subscribe(TOPIC, self._on_picture, qos=QOS_STREAM)
        await self.client.start()
        self._task = asyncio.create_task(self._sharing(), name="pictures:share")
        return self

    async def stop(self) -> None:
        await self.inbox.telemetry.detach("picture share")
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
            self._task = None
        await self.client.stop()

    def _keep(self, msg: Telemetry) -> None:
        self._latest[msg.drone_id] = msg

    async def _sharing(self) -> None:
        while True:
            await asyncio.sleep(self.share_s)
            await self.share()

    async def share(self) -> None:
        """Publish what this replica's drones said since the last picture."""
        latest, self._latest = list(self._latest.values()), {}
        for start in range(0, len(latest), PICTURE_DRONES):
            picture = FleetPicture(
                replica=self.replica, telemetry=latest[start : start + PICTURE_DRONES]
            )
            try:
                await self.client.publish(
                    picture_topic(self.replica),
                    picture,
                    qos=QOS_STREAM,
                    disposable=True,
                )
            except Exception as exc:  # the next picture says it again, newer
                _throttle.log(logging.WARNING, "send", "fleet picture not sent: %s", exc)
                return
            self.sent += len(picture.telemetry)

    async def _on_picture(self, topic_name: str, payload: bytes) -> None:
        if topic_name == picture_topic(self.replica):
            return  # its own
        try:
            picture = parse_message(FleetPicture, payload)
        except MessageError as exc:
            self.dropped["malformed fleet picture"] += 1
            _throttle.log(logging.WARNING, "malformed", "dropping a fleet picture on %s: %s",
                          topic_name, exc)  # fmt: skip
            return
        for msg in picture.telemetry:
            self.inbox.telemetry.hand(msg, peer=True)
        self.taken += len(picture.telemetry)


def picture_topic(replica: str) -> str:
    """Where ``replica`` shares its picture: its name made one topic level (no ``/+#``)."""
    return ground("fleet-picture", "".join(c if c not in "/+#" else "_" for c in replica))
