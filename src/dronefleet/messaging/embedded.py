"""An in-process MQTT broker (amqtt) on a free loopback port: the embedded default.

``dronefleet demo`` and the tests use it so that nothing needs a system service. Real deployments
use Mosquitto or RabbitMQ (docs/DESIGN.md §9). It refuses anonymous clients unless asked to
(``anonymous=True``, for tests that want it): each user comes from ``broker.users``, and
``broker.url_for(name, role)`` makes one and gives the URL with its credentials, which stay in
the process (messaging/embedded_auth.py applies the rules of messaging/broker_acl.py).
"""

from __future__ import annotations

import asyncio
import logging
import random
import socket

from dronefleet.messaging.broker_index import IndexedBroker
from dronefleet.messaging.broker_users import BrokerRole, BrokerUsers
from dronefleet.messaging.embedded_auth import topic_rule
from dronefleet.messaging.url import BrokerUrl

#: Ports :func:`free_port` draws from: below Linux's ephemeral range (32768-60999 by default,
#: /proc/sys/net/ipv4/ip_local_port_range), which the system hands out for ``bind(host, 0)`` and
#: outgoing connections.
PORTS = range(20_000, 32_768)


def free_port(host: str = "127.0.0.1", kind: int = socket.SOCK_STREAM) -> int:
    """A TCP (or, with ``kind=socket.SOCK_DGRAM``, UDP) port nobody is bound to now, for a
    server to bind soon after.

    Drawn at random from :data:`PORTS` and tried, rather than asked of the system with port 0:
    the system gives a port just released to the next ``bind(0)``, so with two processes
    (pytest-xdist workers) each finding a port, one's "free" port was the other's next one, and a
    server bound a moment later failed with "Address already in use"."""
    draw = random.Random()  # its own generator: a test seeding ``random`` must not repeat ports
    for _ in range(100):
        port = draw.choice(PORTS)
        with socket.socket(socket.AF_INET, kind) as sock:
            try:
                sock.bind((host, port))
            except OSError:
                continue
            return port
    with socket.socket(socket.AF_INET, kind) as sock:
        sock.bind((host, 0))
        return int(sock.getsockname()[1])


class EmbeddedBroker:
    """Start with ``await broker.start()`` or ``async with``; ``broker.url`` is where it listens."""

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int | None = None,
        *,
        users: BrokerUsers | None = None,
        anonymous: bool = False,
    ) -> None:
        self.host = host
        self.port = port or free_port(host)
        self.users = users if users is not None else BrokerUsers()
        self.anonymous = anonymous
        self._broker: IndexedBroker | None = None

    @property
    def url(self) -> BrokerUrl:
        """The address, without credentials (an anonymous broker needs none)."""
        return BrokerUrl(self.host, self.port)

    def url_for(self, name: str, role: BrokerRole) -> BrokerUrl:
        """A new user ``name`` (fresh password) and the URL it connects with."""
        password = self.users.add(name, role)
        return BrokerUrl(self.host, self.port, username=name, password=password)

    async def start(self) -> EmbeddedBroker:

        # amqtt logs every connection at INFO; keep our logs readable.
        for name in ("amqtt", "transitions"):
            logging.getLogger(name).setLevel(logging.WARNING)
        rules = {"users": self.users, "anonymous": self.anonymous}
        config = {
            "listeners": {"default": {"type": "tcp", "bind": f"{self.host}:{self.port}"}},
            "plugins": {"dronefleet.messaging.embedded_auth.FleetAuthPlugin": rules},
        }
        broker = self._broker = IndexedBroker(
            config, topic_rule=topic_rule(self.users, self.anonymous)
        )
        await broker.start()
        return self

    async def stop(self) -> None:
        if self._broker is not None:
            broker, self._broker = self._broker, None
            try:
                async with asyncio.timeout(10):
                    await broker.shutdown()
            except (TimeoutError, Exception) as exc:  # a stuck client must not hang shutdown
                logging.getLogger(__name__).warning("embedded broker shutdown: %r", exc)

    async def __aenter__(self) -> EmbeddedBroker:
        return await self.start()

    async def __aexit__(self, *exc: object) -> None:
        await self.stop()
