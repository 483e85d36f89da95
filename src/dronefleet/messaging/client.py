"""The one broker client (aiomqtt) every component uses (seed: the Broker Client submodule).

It reconnects by itself and re-subscribes what was subscribed. Each subscription has its own
ordered queue and worker, so a slow handler never holds up another topic. A handler that raises is
logged and the message dropped: a component never dies on input. Publishing while the broker is
away waits for it to come back (QoS 1 messages are never silently dropped), unless the caller
says the message is disposable (heartbeats, telemetry).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import socket
import ssl
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any

import aiomqtt

# MQTT filter matching (``+``, ``#``) as the broker does it: paho's trie of filters, built once
# per client (paho's topic_matches_sub builds one per call, which a flood made the hot spot).
from paho.mqtt.matcher import MQTTMatcher
from pydantic import BaseModel

from dronefleet.errors import Unavailable
from dronefleet.messaging.acks import AckTicket
from dronefleet.messaging.codec import encode
from dronefleet.messaging.log_throttle import LogThrottle, ThrottleFilter
from dronefleet.messaging.memory import release_freed_memory_soon
from dronefleet.messaging.url import BrokerUrl

log = logging.getLogger(__name__)
_throttle = LogThrottle(log)
_MQTT_LOG = logging.getLogger("dronefleet.mqtt")  # aiomqtt's, throttled
_MQTT_LOG.addFilter(ThrottleFilter())

#: Messages and bytes waiting per subscription; beyond either the oldest are dropped (counted).
QUEUE_LIMIT = 2_000
QUEUE_BYTES = 4 * 1024 * 1024
#: After this many messages, once its queue is empty, a subscription gives freed memory back
#: (messaging/memory.py; at most once per 5 s in a process).
TRIM_AFTER = 200
#: Larger messages are dropped (and counted) before any parsing: a mission of the most steps
#: allowed (messaging/missions.py, 10,000) is about 1.5 MB.
MAX_PAYLOAD_BYTES = 2 * 1024 * 1024

Handler = Callable[[str, bytes], Awaitable[None]]

QOS_COMMAND = 1  # commands, missions, progress, alarms
QOS_STREAM = 0  # heartbeats, telemetry


class BrokerUnavailable(Unavailable, ConnectionError):
    """The broker could not be reached in time."""


@dataclass
class _Subscription:
    pattern: str
    handler: Handler
    qos: int
    queue: asyncio.Queue[tuple[str, bytes, AckTicket | None]] = field(
        default_factory=lambda: asyncio.Queue(QUEUE_LIMIT)
    )
    worker: asyncio.Task[None] | None = None
    dropped: int = 0  # the oldest messages pushed out of a full queue, and oversized ones
    queued_bytes: int = 0
    since_trim: int = 0  # messages taken since freed memory was last given back
    failed: int = 0  # messages its handler raised on


def _no_delay(client: aiomqtt.Client) -> None:
    """Send small packets at once: with Nagle's algorithm each broker hop waited ~40 ms for a
    delayed ACK (measured by bench/command_rtt.py: p50 146 ms -> 18 ms per REST command)."""
    sock: Any = client._client.socket()  # aiomqtt exposes no public handle on paho's socket
    with contextlib.suppress(OSError, AttributeError):
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)


class BrokerClient:
    """A persistent, self-healing connection to one MQTT broker."""

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
        self.client_id = client_id
        self.keepalive_s = keepalive_s
        self.reconnect_s = reconnect_s
        self.persistent_session = persistent_session
        self._subs: list[_Subscription] = []
        self._matcher = MQTTMatcher()  # filter -> its subscriptions
        self._client: aiomqtt.Client | None = None
        self._paho: Any = None  # paho's client under the current connection (for acks)
        self._connected = asyncio.Event()
        self._runner: asyncio.Task[None] | None = None
        self._stopping = False
        self.connections = 0  # how many times a connection was made (1 + reconnects)

    # -- lifecycle ---------------------------------------------------------------------------
    async def start(self, *, timeout_s: float | None = 10.0) -> BrokerClient:
        """Connect (retrying in the background) and wait up to ``timeout_s`` for the first link."""
        if self._runner is None:
            self._stopping = False
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

    @property
    def connected(self) -> bool:
        return self._connected.is_set()

    async def wait_connected(self, timeout_s: float | None = None) -> None:
        async with asyncio.timeout(timeout_s):
            await self._connected.wait()

    # -- subscribe / publish -----------------------------------------------------------------
    async def subscribe(self, pattern: str, handler: Handler, *, qos: int = QOS_COMMAND) -> None:
        """Call ``handler(topic, payload)`` for each message matching ``pattern``, in order."""
        sub = _Subscription(pattern, handler, qos)
        try:
            self._matcher[pattern].append(sub)
        except KeyError:
            self._matcher[pattern] = [sub]
        sub.worker = asyncio.create_task(self._work(sub), name=f"sub:{pattern}")
        self._subs.append(sub)
        if self._client is not None and self.connected:
            with contextlib.suppress(aiomqtt.MqttError):
                await self._client.subscribe(pattern, qos=qos)

    async def publish(
        self,
        topic_name: str,
        message: BaseModel | dict[str, Any] | bytes,
        *,
        qos: int = QOS_COMMAND,
        retain: bool = False,
        disposable: bool = False,
        timeout_s: float | None = None,
    ) -> bool:
        """Publish; wait out broker outages unless ``disposable``. Returns False if dropped."""
        payload = message if isinstance(message, bytes) else encode(message)
        loop = asyncio.get_running_loop()
        deadline = None if timeout_s is None else loop.time() + timeout_s
        while True:
            client = self._client
            if client is not None and self.connected:
                try:
                    await client.publish(topic_name, payload, qos=qos, retain=retain)
                    _keep_cancellation()
                    return True
                except aiomqtt.MqttError as exc:
                    log.debug("publish on %s failed (%s); waiting for the broker", topic_name, exc)
            if disposable:
                return False
            remaining = None if deadline is None else deadline - loop.time()
            if remaining is not None and remaining <= 0:
                raise BrokerUnavailable(f"broker {self.url} unavailable; {topic_name} not sent")
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(min(remaining or 1.0, 1.0)):
                    await self._connected.wait()
            if self._stopping:
                raise BrokerUnavailable(f"client {self.client_id} stopped; {topic_name} not sent")

    # -- internals ---------------------------------------------------------------------------
    @property
    def _queue_type(self) -> type[asyncio.Queue[aiomqtt.Message]]:
        """aiomqtt's incoming queue (its public ``queue_type``), made to hand each message
        straight to our subscriptions' bounded queues as paho delivers it. aiomqtt's own queue
        is unbounded or drops the newest, and its iterator costs a task per message: a flood
        of 100,000 messages left 10,000 waiting there for 30 s after it ended (issue 11)."""
        dispatch = self._dispatch

        class Dispatch(asyncio.Queue[aiomqtt.Message]):
            def put_nowait(self, item: aiomqtt.Message) -> None:
                payload = item.payload
                if not isinstance(payload, bytes | bytearray):
                    payload = str(payload or "").encode()
                dispatch(item.topic.value, bytes(payload), item.mid, item.qos)

        return Dispatch

    async def _run(self) -> None:
        while not self._stopping:
            try:
                connection = aiomqtt.Client(
                    self.url.host,
                    self.url.port,
                    username=self.url.username,
                    password=self.url.password,
                    identifier=self.client_id,
                    clean_session=not self.persistent_session,
                    keepalive=self.keepalive_s,
                    queue_type=self._queue_type,
                    logger=_MQTT_LOG,
                    tls_context=self._tls,
                )
                # A persistent session's messages are acknowledged once handled (acks.py).
                connection._client.manual_ack_set(self.persistent_session)
                # Set before connecting: a resumed session's messages come with the CONNACK.
                self._paho = connection._client
                async with connection as client:
                    self._client = client
                    _no_delay(client)
                    for sub in self._subs:
                        await client.subscribe(sub.pattern, qos=sub.qos)
                    self.connections += 1
                    self._connected.set()
                    log.debug("%s connected to %s", self.client_id, self.url)
                    async for _ in client.messages:  # never yields (see _queue_type): it
                        pass  # ends, raising MqttError, when the link is lost
            except aiomqtt.MqttError as exc:
                if not self._stopping:
                    log.info(
                        "%s: broker %s link lost (%s); retrying", self.client_id, self.url, exc
                    )
            finally:
                self._connected.clear()
                self._client = None
            if not self._stopping:
                await asyncio.sleep(self.reconnect_s)

    def _dispatch(self, topic_name: str, payload: bytes, mid: int = 0, qos: int = 0) -> None:
        subs = [sub for subs in self._matcher.iter_match(topic_name) for sub in subs]
        ticket = None
        if self.persistent_session and qos > 0 and self._paho is not None:
            ticket = AckTicket(self._paho, mid, qos, pending=len(subs))
        for sub in subs:
            if len(payload) > MAX_PAYLOAD_BYTES:
                if ticket is not None:
                    ticket.done()
                sub.dropped += 1
                _throttle.log(logging.WARNING, f"big:{sub.pattern}", "%s: a %d-byte message on %s "
                              "dropped (limit %d)", self.client_id, len(payload), topic_name,
                              MAX_PAYLOAD_BYTES)  # fmt: skip
                continue
            while sub.queue.full() or sub.queued_bytes + len(payload) > QUEUE_BYTES:
                # A flood must not delay what comes after it: the oldest waiting message goes.
                _, old, old_ticket = sub.queue.get_nowait()
                if old_ticket is not None:
                    old_ticket.done()
                sub.queued_bytes -= len(old)
                sub.dropped += 1
                what = "%s: queue for %s full; dropped its oldest message"
                _throttle.log(logging.WARNING, f"full:{sub.pattern}", what, self.client_id,
                              sub.pattern)  # fmt: skip
            sub.queue.put_nowait((topic_name, payload, ticket))
            sub.queued_bytes += len(payload)

    async def _work(self, sub: _Subscription) -> None:
        while True:
            if sub.since_trim >= TRIM_AFTER and sub.queue.empty():
                release_freed_memory_soon()
                sub.since_trim = 0
            topic_name, payload, ticket = await sub.queue.get()
            sub.since_trim += 1
            sub.queued_bytes -= len(payload)
            try:
                await sub.handler(topic_name, payload)
            except asyncio.CancelledError:
                raise  # not acknowledged: delivered again to the next session
            except Exception:
                sub.failed += 1
                what = "handler for %s failed on a message from %s; dropped"
                _throttle.log(logging.ERROR, f"fail:{sub.pattern}", what, sub.pattern,
                              topic_name, exc=True)  # fmt: skip
            if ticket is not None:
                ticket.done()


def _keep_cancellation() -> None:
    """Raise the cancellation aiomqtt may have lost.

    aiomqtt waits for the broker's acknowledgement with Python 3.11's ``asyncio.wait_for``, which
    returns the result instead of raising when the task is cancelled just as the answer comes.
    The task's cancel request is still counted, so it is honoured here; otherwise a publishing
    loop (heartbeats) would never stop and a process would ignore SIGTERM.
    """
    task = asyncio.current_task()
    if task is not None and task.cancelling():
        raise asyncio.CancelledError
