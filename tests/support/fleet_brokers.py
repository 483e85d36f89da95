"""The fleet's brokers as an attacker meets them (tests/security): each with a ground user and
drones A and B made by the project's own code, and raw MQTT connections ("probes") that may carry
Wills, any client id, and no or wrong credentials.

Targets: the embedded default (a broker process), the in-process bus of the simulations, Mosquitto
with the files ``broker_acl.mosquitto_files`` writes, and RabbitMQ with the definitions
``rabbit_acl.rabbitmq_definitions`` writes (in a vhost of the test's own, where the machine has
RabbitMQ's MQTT adapter).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import secrets
import socket
import subprocess
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import aiomqtt

from dronefleet.messaging.broker_acl import mosquitto_files
from dronefleet.messaging.broker_users import BrokerRole, BrokerUsers
from dronefleet.messaging.embedded import EmbeddedBroker
from dronefleet.messaging.local_bus import ConnectRefused, LocalBus, LocalSession, Will
from dronefleet.messaging.rabbit_acl import rabbitmq_definitions
from dronefleet.messaging.url import BrokerUrl
from support.brokers import Mosquitto

KINDS = ("embedded", "local", "mosquitto", "rabbitmq")

Login = tuple[str, str] | None  # (user name as the broker takes it, password), or anonymous


class Probe:
    """One MQTT connection the test drives by hand: what it received, and whether the broker
    refused it or cut it off."""

    def __init__(self) -> None:
        self.got: list[tuple[str, bytes]] = []
        self.refused = False
        self.cut = False  # closed by the broker after it was accepted

    async def publish(self, topic: str, payload: bytes, *, qos: int = 1, retain: bool = False):
        raise NotImplementedError

    async def subscribe(self, pattern: str, *, qos: int = 1) -> None:
        raise NotImplementedError

    async def drop(self) -> None:
        """End the link without a DISCONNECT (a crash, a cut cable): its Will is due."""
        raise NotImplementedError

    async def close(self) -> None:
        raise NotImplementedError


class NetworkProbe(Probe):
    def __init__(self, url: BrokerUrl) -> None:
        super().__init__()
        self.url = url
        self._client: aiomqtt.Client | None = None
        self._reader: asyncio.Task[None] | None = None

    async def open(
        self, client_id: str, login: Login, *, clean: bool, will: Will | None
    ) -> NetworkProbe:
        user, password = login if login is not None else (None, None)
        self._client = aiomqtt.Client(
            self.url.host,
            self.url.port,
            identifier=client_id,
            username=user,
            password=password,
            clean_session=clean,
            keepalive=30,
            timeout=5,
            will=aiomqtt.Will(will.topic, will.payload, will.qos, will.retain) if will else None,
        )
        try:
            await self._client.__aenter__()
        except aiomqtt.MqttError:
            self.refused = True
            self._client = None
            return self
        self._reader = asyncio.create_task(self._read())
        return self

    async def _read(self) -> None:
        assert self._client is not None
        try:
            async for message in self._client.messages:
                self.got.append((str(message.topic), bytes(message.payload)))  # type: ignore[arg-type]
        except aiomqtt.MqttError:
            self.cut = True

    async def publish(self, topic: str, payload: bytes, *, qos: int = 1, retain: bool = False):
        if self._client is None or self.cut:
            return
        with contextlib.suppress(aiomqtt.MqttError):
            await self._client.publish(topic, payload, qos=qos, retain=retain)

    async def subscribe(self, pattern: str, *, qos: int = 1) -> None:
        if self._client is None or self.cut:
            return
        with contextlib.suppress(aiomqtt.MqttError):
            await self._client.subscribe(pattern, qos=qos)

    async def drop(self) -> None:
        if self._client is None:
            return
        sock: Any = self._client._client.socket()
        with contextlib.suppress(OSError, AttributeError):
            sock.shutdown(socket.SHUT_RDWR)
        await self._finish(clean=False)

    async def close(self) -> None:
        await self._finish(clean=True)

    async def _finish(self, *, clean: bool) -> None:
        client, self._client = self._client, None
        if self._reader is not None:
            self._reader.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await self._reader
        if client is not None:
            with contextlib.suppress(Exception):
                async with asyncio.timeout(3):
                    await client.__aexit__(None, None, None)


class LocalProbe(Probe):
    def __init__(self, bus: LocalBus) -> None:
        super().__init__()
        self.bus = bus
        self.session: LocalSession | None = None

    def open(self, client_id: str, login: Login, *, clean: bool, will: Will | None) -> LocalProbe:
        user, password = login if login is not None else (None, None)
        try:
            self.session = self.bus.connect(
                client_id,
                user,
                password,
                clean=clean,
                will=will,
                deliver=lambda topic, payload, _mid, _qos: self.got.append((topic, payload)),
            )
        except ConnectRefused:
            self.refused = True
        return self

    async def publish(self, topic: str, payload: bytes, *, qos: int = 1, retain: bool = False):
        if self.session is not None and not self.session.closed.is_set():
            await self.session.publish(topic, payload, qos, retain)

    async def subscribe(self, pattern: str, *, qos: int = 1) -> None:
        if self.session is not None and not self.session.closed.is_set():
            await self.session.subscribe(pattern, qos)

    async def drop(self) -> None:
        if self.session is not None:
            self.session.drop()

    async def close(self) -> None:
        if self.session is not None:
            self.session.disconnect()


@dataclass
class Target:
    """One broker with users ``ground``, ``A`` and ``B`` (``names`` gives each one's topic
    prefix or user name, ``logins`` what it logs in with)."""

    kind: str
    names: dict[str, str]
    logins: dict[str, tuple[str, str]]
    url: BrokerUrl
    bus: LocalBus | None = None
    probes: list[Probe] = field(default_factory=list)

    def url_of(self, who: str) -> BrokerUrl:
        """The URL the project's own client connects as ``who`` with."""
        user, password = self.logins[who]
        return BrokerUrl(self.url.host, self.url.port, user, password, local=self.url.local)

    async def probe(
        self, client_id: str, login: Login, *, clean: bool = True, will: Will | None = None
    ) -> Probe:
        probe: Probe
        if self.bus is not None:
            probe = LocalProbe(self.bus).open(client_id, login, clean=clean, will=will)
        else:
            probe = await NetworkProbe(self.url).open(client_id, login, clean=clean, will=will)
        self.probes.append(probe)
        return probe

    async def close(self) -> None:
        for probe in self.probes:
            with contextlib.suppress(Exception):
                await probe.close()


def _users(names: dict[str, str]) -> tuple[BrokerUsers, dict[str, tuple[str, str]]]:
    users = BrokerUsers()
    logins = {}
    for who, name in names.items():
        role = BrokerRole.GROUND if who == "ground" else BrokerRole.DRONE
        logins[who] = (name, users.add(name, role))
    return users, logins


@contextlib.asynccontextmanager
async def target(kind: str, tmp: Path, rabbit_port: Callable[[], int]) -> AsyncIterator[Target]:
    """The broker ``kind`` (one of :data:`KINDS`), started, with its users; stopped after."""
    if kind == "rabbitmq":
        async with _rabbitmq(rabbit_port()) as found:
            yield found
        return
    names = {"ground": "ground", "A": "QUAD_1", "B": "QUAD_2"}
    users, logins = _users(names)
    if kind == "mosquitto":
        passwords, acl = mosquitto_files(users)
        (tmp / "passwd").write_text(passwords)
        (tmp / "acl").write_text(acl)
        extra = f"password_file {tmp / 'passwd'}\nacl_file {tmp / 'acl'}\n"
        broker = Mosquitto(tmp, extra, anonymous=False, persistent=True)
        url = await asyncio.to_thread(broker.start)
        found = Target(kind, names, logins, url)
        try:
            yield found
        finally:
            await found.close()
            await asyncio.to_thread(broker.stop)
        return
    started: EmbeddedBroker | LocalBus
    started = LocalBus(users=users) if kind == "local" else EmbeddedBroker(users=users)
    async with started:
        bus = started if isinstance(started, LocalBus) else None
        found = Target(kind, names, logins, started.url, bus=bus)
        try:
            yield found
        finally:
            await found.close()


@contextlib.asynccontextmanager
async def _rabbitmq(port: int) -> AsyncIterator[Target]:
    tag = secrets.token_hex(3).upper()
    names = {"ground": f"secground-{tag.lower()}", "A": f"SQA_{tag}", "B": f"SQB_{tag}"}
    users, logins = _users(names)
    vhost = f"dronefleet-sec-{tag.lower()}"
    document = json.dumps(rabbitmq_definitions(users, vhost)).encode()
    await asyncio.to_thread(
        subprocess.run,
        ["rabbitmqctl", "import_definitions"],
        input=document,
        check=True,
        capture_output=True,
        timeout=60,
    )
    # RabbitMQ's MQTT adapter takes VHOST:USER as the user name.
    vhost_logins = {who: (f"{vhost}:{user}", pw) for who, (user, pw) in logins.items()}
    found = Target("rabbitmq", names, vhost_logins, BrokerUrl("127.0.0.1", port))
    try:
        yield found
    finally:
        await found.close()
        await asyncio.to_thread(_rabbitmqctl, "delete_vhost", vhost)
        for name in names.values():
            await asyncio.to_thread(_rabbitmqctl, "delete_user", name)


def _rabbitmqctl(*args: str) -> str:
    done = subprocess.run(["rabbitmqctl", "-q", *args], capture_output=True, text=True, timeout=60)
    return done.stdout
