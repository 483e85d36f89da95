"""``/api/v1/stream``: live heartbeats, telemetry, mission progress, alarms, fleet changes and the
drones' command answers (``command``: an accepted move's end comes there, drone/command_watch.py).

One :class:`StreamHub` per server fans every message out to the connected WebSockets as
``{"kind", "drone_id", "topic", "data"}``: heartbeats and telemetry as the ground's Fleet Inbox
hands them (ground/inbox.py: read once for every ground service), the rest from its own broker
connection. A message is turned into JSON only when a client wants it. A client may narrow the
stream with ``?drone=ID`` and ``?kinds=heartbeat,telemetry,progress,alarm,fleet,command``. The
separation
monitor's alarms (``ground/separation/alarms``) come as ``alarm`` too. A slow client loses
its oldest messages rather than holding up the others.
"""

import asyncio
import contextlib
import logging
from dataclasses import dataclass, field
from functools import partial
from typing import Any
from urllib.parse import urlsplit

from fastapi import APIRouter, WebSocket, WebSocketDisconnect

from dronefleet.ground.identifier import EVENTS_TOPIC
from dronefleet.ground.inbox import FleetInbox
from dronefleet.ground.manager.auth import Role
from dronefleet.ground.manager.context import ctx_of
from dronefleet.ground.manager.errors import ApiError
from dronefleet.messaging.client import QOS_STREAM, BrokerClient
from dronefleet.messaging.codec import MessageError
from dronefleet.messaging.commands import CommandResponse
from dronefleet.messaging.ground_events import FleetEvent, PlannerEvent
from dronefleet.messaging.inbound import parse_message, speaks_for_itself
from dronefleet.messaging.log_throttle import LogThrottle
from dronefleet.messaging.missions import MissionProgress
from dronefleet.messaging.status import Alarm, Heartbeat, Telemetry
from dronefleet.messaging.topics import (
    PLANNER_EVENTS,
    SEPARATION_ALARMS,
    Channel,
    Direction,
    any_drone,
    parse,
    topic,
)

log = logging.getLogger(__name__)
_throttle = LogThrottle(log)

KINDS = {
    Channel.HEARTBEATS: "heartbeat",
    Channel.TELEMETRY: "telemetry",
    Channel.MISSION: "progress",
    Channel.ALARMS: "alarm",
    Channel.CONTROL: "command",
}
#: The shared model each relayed drone message is validated with (the stream relays no raw dict);
#: heartbeats and telemetry come validated from the Fleet Inbox.
MODELS: dict[Channel, type[MissionProgress | Alarm | CommandResponse]] = {
    Channel.MISSION: MissionProgress,
    Channel.ALARMS: Alarm,
    Channel.CONTROL: CommandResponse,
}
ALL_KINDS = frozenset({*KINDS.values(), "fleet", "mission"})
#: The Mission Planner announces mission changes (state, handovers, extensions) here.
PLANNER_EVENTS_TOPIC = PLANNER_EVENTS
QUEUE_SIZE = 1_000


@dataclass(eq=False)
class _Listener:
    drone: str | None
    kinds: frozenset[str]
    queue: asyncio.Queue[dict[str, Any]] = field(default_factory=lambda: asyncio.Queue(QUEUE_SIZE))

    def wants(self, kind: str, drone_id: str | None) -> bool:
        return kind in self.kinds and (self.drone is None or drone_id == self.drone)

    def offer(self, message: dict[str, Any]) -> None:
        if self.wants(message["kind"], message.get("drone_id")):
            self.put(message)

    def put(self, message: dict[str, Any]) -> None:
        if self.queue.full():
            with contextlib.suppress(asyncio.QueueEmpty):
                self.queue.get_nowait()
        self.queue.put_nowait(message)


#: What the Fleet Inbox hands the hub; the other drone channels come on its own connection.
FROM_INBOX = (Channel.HEARTBEATS, Channel.TELEMETRY)


class StreamHub:
    def __init__(self, broker_url: Any, *, client_id: str, inbox: FleetInbox | None = None) -> None:
        self.client = BrokerClient(broker_url, client_id)
        #: Heartbeats and telemetry; alone (no ground's inbox given), an inbox of its own.
        self.inbox = inbox or FleetInbox(broker_url, client_id=f"{client_id}-inbox")
        self._own_inbox = inbox is None
        self.listeners: set[_Listener] = set()
        self.dropped = 0  # messages that did not validate: counted, not relayed

    async def start(self) -> "StreamHub":
        self.inbox.heartbeats.direct("live stream", partial(self._relay, Channel.HEARTBEATS))
        self.inbox.telemetry.direct("live stream", partial(self._relay, Channel.TELEMETRY))
        for channel in KINDS.keys() - FROM_INBOX:
            await self.client.subscribe(any_drone(channel), self._on_message, qos=1)
        await self.client.subscribe(EVENTS_TOPIC, self._on_message, qos=QOS_STREAM)
        await self.client.subscribe(PLANNER_EVENTS_TOPIC, self._on_message, qos=QOS_STREAM)
        await self.client.subscribe(SEPARATION_ALARMS, self._on_message, qos=1)
        await self.client.start()
        if self._own_inbox:
            await self.inbox.start()
        return self

    async def stop(self) -> None:
        for feed in (self.inbox.heartbeats, self.inbox.telemetry):
            await feed.detach("live stream")
        if self._own_inbox:
            await self.inbox.stop()
        await self.client.stop()

    def _relay(self, channel: Channel, msg: Heartbeat | Telemetry) -> None:
        """A heartbeat or telemetry as the inbox read it, to the clients that want it."""
        if not self.listeners:
            return  # nobody watching: a message costs nothing more here
        kind = KINDS[channel]
        wanting = [listener for listener in self.listeners if listener.wants(kind, msg.drone_id)]
        if not wanting:
            return
        message = {
            "kind": kind,
            "drone_id": msg.drone_id,
            "topic": topic(msg.drone_id, channel, Direction.OUT),
            "data": msg.model_dump(mode="json", exclude_none=True),
        }
        for listener in wanting:
            listener.put(message)

    async def _on_message(self, topic_name: str, payload: bytes) -> None:
        if not self.listeners:
            return
        try:
            kind, drone_id, data = _read(topic_name, payload)
        except (MessageError, ValueError) as exc:
            self.dropped += 1
            _throttle.log(logging.WARNING, "stream", "not relaying %s: %s", topic_name, exc)
            return
        message = {"kind": kind, "drone_id": drone_id, "topic": topic_name, "data": data}
        for listener in list(self.listeners):
            listener.offer(message)


def _read(topic_name: str, payload: bytes) -> tuple[str, str | None, dict[str, Any]]:
    """A broker message as the stream relays it: its kind, drone and validated fields."""
    if topic_name == EVENTS_TOPIC:
        fleet = parse_message(FleetEvent, payload)
        return "fleet", fleet.drone_id, fleet.model_dump(mode="json", exclude_none=True)
    if topic_name == PLANNER_EVENTS_TOPIC:
        mission = parse_message(PlannerEvent, payload)
        data = mission.model_dump(mode="json", exclude_none=True)
        return "mission", data.get("drone_id"), data
    if topic_name == SEPARATION_ALARMS:  # the ground's separation monitor, about two drones
        alarm = parse_message(Alarm, payload)
        return "alarm", alarm.drone_id, alarm.model_dump(mode="json", exclude_none=True)
    where = parse(topic_name)
    msg = parse_message(MODELS[where.channel], payload)
    speaks_for_itself(topic_name, msg.drone_id)
    return KINDS[where.channel], where.drone_id, msg.model_dump(mode="json", exclude_none=True)


router = APIRouter(tags=["stream"])


@router.websocket("/api/v1/stream")
async def stream(websocket: WebSocket) -> None:
    ctx = ctx_of(websocket)
    origin = websocket.headers.get("origin")
    if origin is not None and urlsplit(origin).netloc != websocket.headers.get("host"):
        # A browser page from another site must not read the stream with the operator's token
        # (cross-site WebSocket hijacking); clients that are not browsers send no Origin.
        await websocket.close(code=4403, reason=f"origin {origin} is not this server")
        return
    try:
        await ctx.tokens.principal(websocket, Role.VIEWER)
    except ApiError as exc:
        await websocket.close(code=4401 if exc.status == 401 else 4403, reason=exc.detail)
        return
    kinds_param = websocket.query_params.get("kinds")
    kinds = frozenset(k.strip() for k in kinds_param.split(",")) if kinds_param else ALL_KINDS
    if not kinds <= ALL_KINDS:
        bad = ", ".join(sorted(kinds - ALL_KINDS))
        await websocket.close(code=4422, reason=f"unknown kinds: {bad}")
        return
    await websocket.accept()
    listener = _Listener(websocket.query_params.get("drone"), kinds)
    hub: StreamHub = ctx.hub
    hub.listeners.add(listener)

    async def drain_client() -> None:  # notices the client leaving
        with contextlib.suppress(WebSocketDisconnect):
            while True:
                await websocket.receive_text()

    reader = asyncio.create_task(drain_client())
    try:
        while not reader.done():
            getter = asyncio.ensure_future(listener.queue.get())
            done, _ = await asyncio.wait({getter, reader}, return_when=asyncio.FIRST_COMPLETED)
            if getter not in done:
                getter.cancel()
                break
            await websocket.send_json(getter.result())
    except (WebSocketDisconnect, RuntimeError):
        pass
    finally:
        hub.listeners.discard(listener)
        reader.cancel()
        with contextlib.suppress(asyncio.CancelledError, Exception):
            await reader
