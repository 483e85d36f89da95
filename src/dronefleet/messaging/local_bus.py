"""The in-process bus: a broker for simulations that run on virtual time (docs/DESIGN.md §3-4).

The embedded default is a real broker process (messaging/nats_broker.py). A broker in another
process holds messages the virtual-time loop (virtual_loop.py) cannot see: while a message is in
flight there, every task here waits, the loop takes the pause for idleness and moves vehicle time
on, and the figures of an experiment would depend on the machine's load. The experiments, the
virtual-time tests and the simulator's benchmarks therefore pass their messages through this bus:
each delivery is a ``put_nowait`` on the receiving client's queue, seen by the loop as ready work,
so a broker hop takes zero vehicle seconds and the order of events is the same in every run.

It keeps the broker's rules, the same ones a deployment's broker applies (messaging/broker_acl.py
for every user, including the rules that matter when one drone's credentials are stolen):

- CONNECT needs a user of :class:`BrokerUsers` and its password; anonymous clients only on a bus
  made with ``anonymous=True`` (tests that ask for it). A refused CONNECT changes nothing.
- A session belongs to the user that made it: a CONNECT with another user's client id is refused
  (MQTT lets any client take over an id it knows; here ids are bound to users), and only the same
  user may take its own session over or resume it.
- A Will is checked as a PUBLISH of its user when the CONNECT arrives (a forbidden Will refuses
  the CONNECT, as Mosquitto does) and published only when a session ends without a DISCONNECT.
- PUBLISH and SUBSCRIBE are checked against the user's rights (a forbidden PUBLISH is dropped and
  counted, a forbidden filter gets ``0x80``); retained messages go only to subscribers who may
  read their topic.
- QoS 1 to a persistent session is kept until acknowledged: a session that goes before it acks
  gets the message again when it comes back (the messages are queued for it meanwhile).

There is no network, so nothing outside this process can reach it at all, and no keep-alive:
a session ends when its client stops or is dropped.
"""

from __future__ import annotations

import asyncio
import itertools
import secrets
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from paho.mqtt.client import topic_matches_sub
from paho.mqtt.matcher import MQTTMatcher

from dronefleet.errors import Unavailable
from dronefleet.messaging.broker_acl import may_publish, may_subscribe
from dronefleet.messaging.broker_users import BrokerRole, BrokerUser, BrokerUsers
from dronefleet.messaging.url import BrokerUrl

#: QoS 1 messages kept for a persistent session that is away; beyond it the oldest go (counted).
OFFLINE_LIMIT = 10_000
#: Topics whose subscribers are remembered (:meth:`LocalBus.route`); beyond it the memory starts
#: again, so junk topics cannot grow it.
ROUTE_CACHE_LIMIT = 50_000
ROUTE_CACHE_TOPIC = 128  # longer topics are matched each time, not remembered
#: SUBACK's failure code (MQTT 3.1.1, 3.9.3).
SUBACK_FAILURE = 0x80

#: ``deliver(topic, payload, mid, qos)``: hands one message to the connected client.
Deliver = Callable[[str, bytes, int, int], None]

_buses: dict[str, LocalBus] = {}


class ConnectRefused(Unavailable, ConnectionError):
    """CONNACK with a non-zero return code (MQTT 3.1.1, 3.2.2.3)."""

    def __init__(self, code: int, why: str) -> None:
        super().__init__(f"connection refused ({code}): {why}")
        self.code = code


class SessionClosed(Unavailable, ConnectionError):
    """The session's link is gone (taken over, or the bus stopped)."""


@dataclass(frozen=True)
class Will:
    topic: str
    payload: bytes
    qos: int = 0
    retain: bool = False


@dataclass(slots=True)
class _Message:
    topic: str
    payload: bytes
    qos: int


@dataclass
class _State:
    """What the bus keeps of one client id: its owner, filters and unacknowledged messages."""

    client_id: str
    user: BrokerUser | None
    persistent: bool
    filters: dict[str, int] = field(default_factory=dict)
    offline: deque[_Message] = field(default_factory=deque)  # queued while away
    inflight: dict[int, _Message] = field(default_factory=dict)  # delivered, not acked
    link: LocalSession | None = None


def _valid_topic(name: str) -> bool:
    return 0 < len(name) <= 65_535 and "+" not in name and "#" not in name and "\0" not in name


def _valid_filter(pattern: str) -> bool:
    if not pattern or "\0" in pattern:
        return False
    levels = pattern.split("/")
    for i, level in enumerate(levels):
        if "#" in level and (level != "#" or i != len(levels) - 1):
            return False
        if "+" in level and level != "+":
            return False
    return True


class LocalSession:
    """One client's link to the bus: what ``aiomqtt.Client`` is to a broker process."""

    def __init__(self, bus: LocalBus, state: _State, deliver: Deliver, will: Will | None) -> None:
        self._bus = bus
        self._state = state
        self._deliver = deliver
        self._will = will
        self._mids = itertools.count(1)
        self.closed = asyncio.Event()

    @property
    def client_id(self) -> str:
        return self._state.client_id

    async def publish(self, topic: str, payload: bytes, qos: int = 0, retain: bool = False) -> None:
        """Route one message; a forbidden or malformed one is dropped (counted), as a broker
        drops it without telling an MQTT 3.1.1 publisher."""
        self._check_open()
        self._bus.route(self._state.user, topic, bytes(payload), qos, retain)
        await asyncio.sleep(0)  # a real suspension point, as a socket write is

    async def subscribe(self, pattern: str, qos: int = 0) -> int:
        """The granted QoS, or :data:`SUBACK_FAILURE`; retained messages follow at once."""
        self._check_open()
        granted = self._bus.subscribe(self._state, pattern, min(qos, 1))
        await asyncio.sleep(0)
        return granted

    async def unsubscribe(self, pattern: str) -> None:
        self._check_open()
        self._bus.unsubscribe(self._state, pattern)
        await asyncio.sleep(0)

    def ack(self, mid: int, qos: int) -> None:
        """PUBACK for a message delivered to a persistent session (messaging/acks.py)."""
        if self._state.link is self:
            self._state.inflight.pop(mid, None)

    def disconnect(self) -> None:
        """A clean DISCONNECT: the Will is discarded."""
        self._will = None
        self._close()

    def drop(self) -> None:
        """The link lost without a DISCONNECT: the Will, if any, is published."""
        self._close()

    # -- internals ------------------------------------------------------------------------------
    def _check_open(self) -> None:
        if self.closed.is_set():
            raise SessionClosed(f"session {self.client_id} is closed")

    def _close(self) -> None:
        if self.closed.is_set():
            return
        self.closed.set()
        self._bus.detach(self._state, self)
        will, self._will = self._will, None
        if will is not None:
            self._bus.route(self._state.user, will.topic, will.payload, will.qos, will.retain)

    def requeue(self, message: _Message) -> None:
        if self._state.persistent:
            self._state.offline.append(message)

    def send(self, message: _Message) -> None:
        mid = 0
        if message.qos > 0 and self._state.persistent:
            mid = next(self._mids)
            self._state.inflight[mid] = message
        self._deliver(message.topic, message.payload, mid, message.qos)


class LocalBus:
    """A broker in this process: ``bus.url_for(name, role)`` gives a ``local://`` URL that
    :class:`~dronefleet.messaging.client.BrokerClient` connects with; start and stop it like the
    embedded broker (``async with LocalBus() as bus``)."""

    def __init__(self, *, users: BrokerUsers | None = None, anonymous: bool = False) -> None:
        self.name = f"bus-{secrets.token_hex(8)}"
        self.users = users if users is not None else BrokerUsers()
        self.anonymous = anonymous
        self._states: dict[str, _State] = {}
        self._links: dict[str, LocalSession] = {}  # connected client ids
        self._matcher = MQTTMatcher()  # filter -> {client id: qos}
        # topic -> its subscribers' states and QoS, kept until any filter changes: a fleet's
        # topics are few and each is published thousands of times (paho's matcher walks its trie
        # with recursive generators, the top cost of bench/sim_scale.py at 1000 drones).
        self._routes: dict[str, tuple[tuple[_State, int], ...]] = {}
        self._retained: dict[str, _Message] = {}
        #: Refused or dropped: CONNECTs, PUBLISHes, filters, queued messages pushed out.
        self.refused: dict[str, int] = {"connect": 0, "publish": 0, "subscribe": 0, "offline": 0}

    # -- the embedded broker's interface -------------------------------------------------------
    @property
    def url(self) -> BrokerUrl:
        return BrokerUrl(self.name, 0, local=True)

    def url_for(self, name: str, role: BrokerRole) -> BrokerUrl:
        """A new user ``name`` (fresh password) and the URL it connects with."""
        password = self.users.add(name, role)
        return BrokerUrl(self.name, 0, username=name, password=password, local=True)

    def urls_for(self, names: Sequence[str], role: BrokerRole) -> list[BrokerUrl]:
        """:meth:`url_for` for each of ``names`` (as the NATS broker's, which reloads once)."""
        return [self.url_for(name, role) for name in names]

    async def start(self) -> LocalBus:
        _buses[self.name] = self
        return self

    async def stop(self) -> None:
        _buses.pop(self.name, None)
        for link in list(self._links.values()):
            link.drop()

    async def __aenter__(self) -> LocalBus:
        return await self.start()

    async def __aexit__(self, *exc: object) -> None:
        await self.stop()

    @staticmethod
    def find(name: str) -> LocalBus:
        try:
            return _buses[name]
        except KeyError:
            raise ConnectionRefusedError(f"no in-process bus {name!r} is running") from None

    # -- CONNECT --------------------------------------------------------------------------------
    def connect(
        self,
        client_id: str,
        username: str | None,
        password: str | None,
        *,
        clean: bool,
        deliver: Deliver,
        will: Will | None = None,
    ) -> LocalSession:
        """A session for ``client_id``, or :class:`ConnectRefused` (nothing changed)."""
        user = self._authenticate(username, password)
        state = self._states.get(client_id)
        if state is not None and _owner(state) != _owner_of(user):
            self.refused["connect"] += 1
            raise ConnectRefused(2, f"client id {client_id!r} belongs to another user")
        if will is not None and not (_valid_topic(will.topic) and _allowed_pub(user, will.topic)):
            self.refused["connect"] += 1
            raise ConnectRefused(5, f"will on {will.topic!r} is not allowed")
        if state is not None and state.link is not None:
            state.link.drop()  # taken over by its own user: the old link ends
            state = self._states.get(client_id)  # gone if it was not persistent
        if state is None or clean or not state.persistent:
            if state is not None:
                self._forget(state)
            state = self._states[client_id] = _State(client_id, user, persistent=not clean)
        link = LocalSession(self, state, deliver, will)
        state.link = link
        self._links[client_id] = link
        # Resumed: what was delivered but not acknowledged comes again, then what queued.
        backlog = list(state.inflight.values()) + list(state.offline)
        state.inflight.clear()
        state.offline.clear()
        asyncio.get_running_loop().call_soon(self._replay, link, backlog)
        return link

    def _authenticate(self, username: str | None, password: str | None) -> BrokerUser | None:
        if username is None and self.anonymous:
            return None
        user = self.users.authenticate(username, password)
        if user is None:
            self.refused["connect"] += 1
            raise ConnectRefused(5 if username is None else 4, "bad user name or password")
        return user

    def _replay(self, link: LocalSession, backlog: list[_Message]) -> None:
        for message in backlog:
            if link.closed.is_set():
                link.requeue(message)
            else:
                link.send(message)

    def detach(self, state: _State, link: LocalSession) -> None:
        if state.link is not link:
            return
        state.link = None
        self._links.pop(state.client_id, None)
        if state.persistent:
            state.offline.extendleft(reversed(list(state.inflight.values())))
            state.inflight.clear()
        else:
            self._forget(state)

    def _forget(self, state: _State) -> None:
        for pattern in state.filters:
            self._filter_changed(pattern)
        for pattern in state.filters:
            try:
                with_qos: dict[str, int] = self._matcher[pattern]
            except KeyError:
                continue
            with_qos.pop(state.client_id, None)
            if not with_qos:
                del self._matcher[pattern]
        state.filters.clear()
        if self._states.get(state.client_id) is state:
            del self._states[state.client_id]

    # -- SUBSCRIBE and PUBLISH -----------------------------------------------------------------
    def subscribe(self, state: _State, pattern: str, qos: int) -> int:
        if not _valid_filter(pattern) or not _allowed_sub(state.user, pattern, self.anonymous):
            self.refused["subscribe"] += 1
            return SUBACK_FAILURE
        state.filters[pattern] = qos
        self._filter_changed(pattern)
        try:
            self._matcher[pattern][state.client_id] = qos
        except KeyError:
            self._matcher[pattern] = {state.client_id: qos}
        link = state.link
        for topic, message in list(self._retained.items()):
            readable = link is not None and topic_matches_sub(pattern, topic)
            if readable and _allowed_sub(state.user, topic, self.anonymous):
                assert link is not None
                link.send(_Message(topic, message.payload, min(qos, message.qos)))
        return qos

    def unsubscribe(self, state: _State, pattern: str) -> None:
        if state.filters.pop(pattern, None) is None:
            return
        self._filter_changed(pattern)
        try:
            with_qos: dict[str, int] = self._matcher[pattern]
        except KeyError:
            return
        with_qos.pop(state.client_id, None)
        if not with_qos:
            del self._matcher[pattern]

    def _filter_changed(self, pattern: str) -> None:
        """Forget the subscribers remembered for the topics ``pattern`` matches: a topic's own
        (no wildcard: a fleet's start-up is thousands of those), else all."""
        if "+" in pattern or "#" in pattern:
            self._routes.clear()
        else:
            self._routes.pop(pattern, None)

    def route(
        self, user: BrokerUser | None, topic: str, payload: bytes, qos: int, retain: bool
    ) -> None:
        if not _valid_topic(topic) or not _allowed_pub(user, topic):
            self.refused["publish"] += 1
            return
        qos = min(qos, 1)
        if retain:
            if payload:
                self._retained[topic] = _Message(topic, payload, qos)
            else:
                self._retained.pop(topic, None)
        targets = self._routes.get(topic)
        if targets is None:
            targets = self._targets(topic)
        by_qos: list[_Message | None] = [None, None]  # one message per QoS, shared (never changed)
        for state, sub_qos in targets:
            message_qos = qos if qos < sub_qos else sub_qos
            message = by_qos[message_qos]
            if message is None:
                message = by_qos[message_qos] = _Message(topic, payload, message_qos)
            link = state.link
            if link is not None:
                link.send(message)
            elif state.persistent and message_qos > 0:
                if len(state.offline) >= OFFLINE_LIMIT:
                    state.offline.popleft()
                    self.refused["offline"] += 1
                state.offline.append(message)

    def _targets(self, topic: str) -> tuple[tuple[_State, int], ...]:
        """Who is subscribed to ``topic``, each once with its highest QoS (remembered)."""
        best: dict[str, int] = {}
        for with_qos in self._matcher.iter_match(topic):
            for client_id, sub_qos in with_qos.items():
                best[client_id] = max(best.get(client_id, 0), sub_qos)
        targets = tuple((self._states[client_id], sub_qos) for client_id, sub_qos in best.items())
        if len(topic) <= ROUTE_CACHE_TOPIC:
            if len(self._routes) >= ROUTE_CACHE_LIMIT:
                self._routes.clear()
            self._routes[topic] = targets
        return targets


def _owner_of(user: BrokerUser | None) -> str | None:
    return None if user is None else user.name


def _owner(state: _State) -> str | None:
    return _owner_of(state.user)


def _allowed_pub(user: BrokerUser | None, topic: str) -> bool:
    return user is None or may_publish(user, topic)


def _allowed_sub(user: BrokerUser | None, pattern: str, anonymous: bool) -> bool:
    return (user is None and anonymous) or (user is not None and may_subscribe(user, pattern))
