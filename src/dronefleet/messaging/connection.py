"""A broker client's link: made, lost and made again by itself, to an MQTT broker or a local bus.

:class:`Connection` is the half of :class:`~dronefleet.messaging.client.BrokerClient` that holds
the link; the client says what is done on each new link (:meth:`Connection._link_up`: subscribe
again) and where messages go (:meth:`Connection._dispatch`).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import socket
import ssl
from collections.abc import Coroutine
from typing import Any, TypedDict, TypeVar

import aiomqtt

from dronefleet.errors import Unavailable
from dronefleet.messaging.client_ids import unguessable_id
from dronefleet.messaging.local_bus import LocalBus, LocalSession, SessionClosed
from dronefleet.messaging.log_throttle import LogThrottle, ThrottleFilter
from dronefleet.messaging.mqtt_link import closed_before_connack_fails, linked
from dronefleet.messaging.mqtt_queue import dispatching_queue
from dronefleet.messaging.node_turns import STABLE_LINK_S, NodeTurns
from dronefleet.messaging.read_buffer import read_buffered
from dronefleet.messaging.url import BrokerNode, BrokerUrl
from dronefleet.virtual_loop import every_wall_s

log = logging.getLogger(__name__)
T = TypeVar("T")
_throttle = LogThrottle(log)
_MQTT_LOG = logging.getLogger("dronefleet.mqtt")  # aiomqtt's, throttled
_MQTT_LOG.addFilter(ThrottleFilter())


class BrokerUnavailable(Unavailable, ConnectionError):
    """The broker could not be reached in time."""


def _no_delay(client: aiomqtt.Client) -> None:
    """Send small packets at once: with Nagle's algorithm each broker hop waited ~40 ms for a
    delayed ACK (measured by bench/command_rtt.py: p50 146 ms -> 18 ms per REST command)."""
    sock: Any = client._client.socket()  # aiomqtt exposes no public handle on paho's socket
    with contextlib.suppress(OSError, AttributeError):
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)


class LinkOptions(TypedDict, total=False):
    """How a :class:`Connection` keeps its link (its keyword arguments)."""

    keepalive_s: int
    reconnect_s: float
    persistent_session: bool


class Connection:
    """The link to one MQTT broker (or local bus), made again whenever it is lost: to the next
    node of a cluster (``url.nodes``) in turn, with the same client id and session flag, so a
    persistent session the cluster replicates is taken up again on another node."""

    def __init__(
        self,
        url: str | BrokerUrl,
        client_id: str,
        *,
        keepalive_s: int = 15,
        reconnect_s: float = 0.5,
        persistent_session: bool = False,
    ) -> None:
        self.url = url if isinstance(url, BrokerUrl) else BrokerUrl.parse(url)
        # mqtts://: the broker's certificate is checked (against ?cafile=, else the system's
        # CAs) and its name must match; never an unverified TLS link (issue 12).
        self._tls = ssl.create_default_context(cafile=self.url.ca_file) if self.url.tls else None
        if self._tls is not None and self.url.cert_file:
            self._tls.load_cert_chain(self.url.cert_file, self.url.key_file)
        self.client_id = unguessable_id(client_id, self.url, persistent=persistent_session)
        self.keepalive_s = keepalive_s
        self.reconnect_s = reconnect_s
        self.persistent_session = persistent_session
        self._client: aiomqtt.Client | LocalSession | None = None
        self._paho: Any = None  # paho's client under the current connection (for acks)
        self._connected = asyncio.Event()
        self._runner: asyncio.Task[None] | None = None
        self._stopping = False
        self.connections = 0  # how many times a connection was made (1 + reconnects)
        self.node: BrokerNode | None = None  # the node of a cluster the link is to, while up
        self._link_lost = asyncio.Event()  # set when the current link ends

    @property
    def connected(self) -> bool:
        return self._connected.is_set()

    async def wait_connected(self, timeout_s: float | None = None) -> None:
        async with asyncio.timeout(timeout_s):
            await self._connected.wait()

    async def _on_link(self, operation: Coroutine[Any, Any, T]) -> T:
        """``operation`` on the current link, ended by an MqttError if that link is lost first.
        A QoS 1 publish waits for its PUBACK, which a killed node never sends: aiomqtt waited
        its whole timeout (10 s) before the message was sent again through another node."""
        lost = self._link_lost
        task = asyncio.ensure_future(operation)
        watch = asyncio.ensure_future(lost.wait())
        try:
            await asyncio.wait((task, watch), return_when=asyncio.FIRST_COMPLETED)
        finally:
            watch.cancel()
            if not task.done():
                task.cancel()
        if task.done() and not task.cancelled():
            return task.result()
        raise aiomqtt.MqttError("the link was lost before the broker answered")

    # -- what the client does with the link ----------------------------------------------------
    async def _link_up(self, client: Any) -> None:
        """Made ready on a new link (``client``), before it counts as connected."""
        raise NotImplementedError

    def _dispatch(
        self, topic_name: str, payload: bytes, mid: int = 0, qos: int = 0, link: Any = None
    ) -> None:
        """Hand a message that came on the link to whoever subscribed to it."""
        raise NotImplementedError

    # -- the reconnect loop ----------------------------------------------------------------------
    async def _run(self) -> None:
        if self.url.local:
            await self._run_local()
            return
        turns = NodeTurns(self.url.nodes, stable_s=max(self.reconnect_s, STABLE_LINK_S))
        while not self._stopping:
            node = turns.next()
            try:
                connection = aiomqtt.Client(
                    node.host,
                    node.port,
                    username=self.url.username,
                    password=self.url.password,
                    identifier=self.client_id,
                    clean_session=not self.persistent_session,
                    keepalive=self.keepalive_s,
                    queue_type=dispatching_queue(self._dispatch),
                    logger=_MQTT_LOG,
                    tls_context=self._tls,
                )
                # A persistent session's messages are acknowledged once handled (acks.py).
                connection._client.manual_ack_set(self.persistent_session)
                # Set before connecting: a resumed session's messages come with the CONNACK.
                self._paho = connection._client
                closed_before_connack_fails(connection)
                read_buffered(connection)  # many packets per read (messaging/read_buffer.py)
                async with linked(connection, turns.connack_s()) as client:
                    # aiomqtt sends the keepalive pings from a task timed on the loop's clock,
                    # which stands still in a simulation while a thread works for the loop; the
                    # broker keeps wall time and closed every idle link of a busy demo.
                    pings = every_wall_s(1.0, connection._client.loop_misc)
                    try:
                        self._client = client
                        self._link_lost = asyncio.Event()
                        self.node = node
                        turns.up()
                        _no_delay(client)
                        await self._link_up(client)
                        self.connections += 1
                        self._connected.set()
                        log.log(
                            logging.INFO if self.connections > 1 else logging.DEBUG,
                            "%s connected to %s (node %s)", self.client_id, self.url, node,
                        )  # fmt: skip
                        async for _ in client.messages:  # never yields (mqtt_queue.py): it
                            pass  # ends, raising MqttError, when the link is lost
                    finally:
                        if pings is not None:
                            pings.cancel()
            except aiomqtt.MqttError as exc:
                if not self._stopping:
                    log.info(
                        "%s: broker %s, node %s: %s %s; trying node %s",
                        self.client_id, self.url, node,
                        "link lost" if self.node == node else "no link", exc, turns.peek(),
                    )  # fmt: skip
            finally:
                self._connected.clear()
                self._client = None
                self.node = None
                self._link_lost.set()
                turns.down()
            if not self._stopping and turns.pause_due():
                await asyncio.sleep(self.reconnect_s)

    async def _run_local(self) -> None:
        """The same life on an in-process bus (messaging/local_bus.py): connect, subscribe,
        wait until the link ends, reconnect."""
        while not self._stopping:
            try:
                bus = LocalBus.find(self.url.host)
                session = bus.connect(
                    self.client_id,
                    self.url.username,
                    self.url.password,
                    clean=not self.persistent_session,
                    deliver=self._dispatch,
                )
            except ConnectionError as exc:
                _throttle.log(logging.INFO, f"local:{self.client_id}", "%s: bus %s: %s; "
                              "retrying", self.client_id, self.url, exc)  # fmt: skip
            else:
                self._paho = session  # acknowledges a persistent session's messages (acks.py)
                self._client = session
                try:
                    await self._link_up(session)
                    self.connections += 1
                    self._connected.set()
                    await session.closed.wait()
                except SessionClosed:
                    pass
                finally:
                    self._connected.clear()
                    self._client = None
                    if self._stopping:
                        session.disconnect()
            if not self._stopping:
                await asyncio.sleep(self.reconnect_s)
