"""An in-process MQTT broker (amqtt) on a free loopback port: the embedded default.

``dronefleet demo`` and the tests use it so that nothing needs a system service. Real deployments
use Mosquitto or RabbitMQ (docs/DESIGN.md §9).
"""

from __future__ import annotations

import asyncio
import logging
import socket

from dronefleet.messaging.broker_index import IndexedBroker
from dronefleet.messaging.url import BrokerUrl


def free_port(host: str = "127.0.0.1") -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind((host, 0))
        return int(sock.getsockname()[1])


class EmbeddedBroker:
    """Start with ``await broker.start()`` or ``async with``; ``broker.url`` is where it listens."""

    def __init__(self, host: str = "127.0.0.1", port: int | None = None) -> None:
        self.host = host
        self.port = port or free_port(host)
        self._broker: IndexedBroker | None = None

    @property
    def url(self) -> BrokerUrl:
        return BrokerUrl(self.host, self.port)

    async def start(self) -> EmbeddedBroker:

        # amqtt logs every connection at INFO; keep our logs readable.
        for name in ("amqtt", "transitions"):
            logging.getLogger(name).setLevel(logging.WARNING)
        config = {
            "listeners": {"default": {"type": "tcp", "bind": f"{self.host}:{self.port}"}},
            "plugins": {
                "amqtt.plugins.authentication.AnonymousAuthPlugin": {"allow_anonymous": True}
            },
        }
        broker = self._broker = IndexedBroker(config)
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
