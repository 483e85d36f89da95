"""The UAVTalk session of the Flight Controller Interface (seed 4.1.2.1).

"If a physical Flight Controller connection is detected, this submodule will establish a session
with it and ensure that no other session is created. Methods for acquiring and sending data
objects to the Flight Controller are then made available." :class:`UAVTalkLink` is that session
over TCP (a serial bridge such as ``ser2net`` or our simulator): one reader task decodes frames and
keeps the latest value of every object; :meth:`request` (OBJ_REQ -> OBJ | NACK) and :meth:`write`
(OBJ_ACK -> ACK | NACK) are transactions with a timeout and retries; :meth:`subscribe` delivers
updates as they come. A dropped connection is re-opened in the background.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections import defaultdict
from collections.abc import Callable
from typing import Any

from dronefleet.protocols.uavtalk.framing import Frame, FrameParser, MessageType, encode_frame
from dronefleet.protocols.uavtalk.objects import ObjectDef
from dronefleet.protocols.uavtalk.registry import ObjectRegistry, default_registry
from dronefleet.vehicle.base import FcError, FcRefused

log = logging.getLogger(__name__)

#: Our extension object that says why the last acked write was refused (a NACK cannot).
STATUS_OBJECT = "FlightCommandStatus"

Listener = Callable[[str, int, dict[str, Any]], None]


class LinkError(FcError):
    """The UAVTalk link is down or the autopilot did not answer in time."""


class Refused(FcRefused):
    """The autopilot NACKed a request or write; the message carries its reason when known."""


class UAVTalkLink:
    """One UAVTalk session to one flight controller."""

    def __init__(
        self,
        host: str,
        port: int,
        registry: ObjectRegistry | None = None,
        *,
        timeout_s: float = 1.0,
        retries: int = 3,
        reconnect: bool = True,
    ) -> None:
        self.host, self.port = host, port
        self.registry = registry or default_registry()
        self.timeout_s = timeout_s
        self.retries = retries
        self.reconnect = reconnect
        self._reader: asyncio.StreamReader | None = None
        self._writer: asyncio.StreamWriter | None = None
        self._task: asyncio.Task[None] | None = None
        self._closing = False
        self._connected = asyncio.Event()
        self._latest: dict[tuple[str, int], dict[str, Any]] = {}
        self._updated: dict[str, asyncio.Event] = defaultdict(asyncio.Event)
        self._pending: dict[tuple[str, int, int], asyncio.Future[Frame]] = {}
        self._locks: dict[int, asyncio.Lock] = defaultdict(asyncio.Lock)
        self._listeners: list[tuple[str | None, Listener]] = []
        self._reconnect_hooks: list[Callable[[], Any]] = []
        self._hook_tasks: set[asyncio.Task[None]] = set()
        self.parser = FrameParser(self.registry.multi_instance)

    @property
    def url(self) -> str:
        return f"tcp:{self.host}:{self.port}"

    @property
    def connected(self) -> bool:
        return self._connected.is_set()

    # -- session -------------------------------------------------------------------------------
    async def open(self, timeout_s: float = 5.0) -> None:
        """Connect; raises :class:`LinkError` if nothing answers at the URL."""
        if self.connected:
            return
        self._closing = False
        try:
            async with asyncio.timeout(timeout_s):
                await self._connect()
        except (OSError, TimeoutError) as exc:
            raise LinkError(f"no UAVTalk flight controller at {self.url}: {exc}") from exc
        self._task = asyncio.create_task(self._run(), name=f"uavtalk-{self.url}")

    async def _connect(self) -> None:
        self._reader, self._writer = await asyncio.open_connection(self.host, self.port)
        self.parser = FrameParser(self.registry.multi_instance)
        self._connected.set()
        log.info("UAVTalk link to %s up", self.url)

    async def close(self) -> None:
        self._closing = True
        task, self._task = self._task, None
        if task is not None:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
        self._drop("link closed")

    def _drop(self, why: str) -> None:
        self._connected.clear()
        if self._writer is not None:
            self._writer.close()
            self._writer = None
        for future in self._pending.values():
            if not future.done():
                future.set_exception(LinkError(f"UAVTalk link to {self.url}: {why}"))
        self._pending.clear()

    async def _run(self) -> None:
        backoff_s = 0.2
        while not self._closing:
            try:
                await self._read_until_eof()
            except (OSError, asyncio.IncompleteReadError) as exc:
                log.warning("UAVTalk link to %s failed: %s", self.url, exc)
            self._drop("connection lost")
            if not self.reconnect or self._closing:
                return
            while not self._closing:
                await asyncio.sleep(backoff_s)
                try:
                    await self._connect()
                except OSError:
                    backoff_s = min(backoff_s * 2, 5.0)
                    continue
                backoff_s = 0.2
                for hook in self._reconnect_hooks:
                    task = asyncio.create_task(self._run_hook(hook))
                    self._hook_tasks.add(task)
                    task.add_done_callback(self._hook_tasks.discard)
                break

    async def _run_hook(self, hook: Callable[[], Any]) -> None:
        try:
            await hook()
        except FcError as exc:
            log.warning("after reconnecting to %s: %s", self.url, exc)

    async def _read_until_eof(self) -> None:
        reader = self._reader
        assert reader is not None
        while chunk := await reader.read(4096):
            for frame in self.parser.feed(chunk):
                self._dispatch(frame)
        log.warning("UAVTalk link to %s closed by the other end", self.url)

    # -- incoming ------------------------------------------------------------------------------
    def _dispatch(self, frame: Frame) -> None:
        definition = self.registry.by_id.get(frame.object_id)
        kind = frame.type
        if kind is MessageType.NACK:
            for key, future in list(self._pending.items()):
                if key[1] == frame.object_id and not future.done():
                    future.set_result(frame)
            return
        if definition is None:
            return  # an object we have no definition for: nothing to decode it with
        if kind.carries_data:
            try:
                values = definition.decode(frame.data)
            except ValueError as exc:
                log.debug("dropping %s: %s", definition.name, exc)
                return
            self._store(definition, frame.instance_id, values)
            self._resolve(MessageType.OBJ_REQ, frame)
            if kind in (MessageType.OBJ_ACK, MessageType.OBJ_ACK_TS):
                self._send(Frame(MessageType.ACK, frame.object_id, frame.instance_id))
        elif kind is MessageType.ACK:
            self._resolve(MessageType.OBJ_ACK, frame)

    def _resolve(self, waiting_kind: MessageType, frame: Frame) -> None:
        future = self._pending.get((waiting_kind.name, frame.object_id, frame.instance_id))
        if future is not None and not future.done():
            future.set_result(frame)

    def _store(self, definition: ObjectDef, instance: int, values: dict[str, Any]) -> None:
        self._latest[definition.name, instance] = values
        event = self._updated[definition.name]
        event.set()
        event.clear()
        for name, listener in self._listeners:
            if name in (None, definition.name):
                try:
                    listener(definition.name, instance, values)
                except Exception:
                    log.exception("UAVTalk listener for %s failed", definition.name)

    # -- API -----------------------------------------------------------------------------------
    def latest(self, name: str, instance: int = 0) -> dict[str, Any] | None:
        """The last value received for an object (wire units), or None."""
        return self._latest.get((name, instance))

    def subscribe(self, name: str | None, listener: Listener) -> None:
        """Call ``listener(name, instance, values)`` on every update of ``name`` (None: all)."""
        self._listeners.append((name, listener))

    def on_reconnect(self, hook: Callable[[], Any]) -> None:
        """Run the coroutine function ``hook()`` after each automatic reconnection."""
        self._reconnect_hooks.append(hook)

    async def wait_update(self, name: str, timeout_s: float) -> dict[str, Any]:
        """Wait for the next update of ``name``; raises :class:`LinkError` after ``timeout_s``."""
        try:
            async with asyncio.timeout(timeout_s):
                await self._updated[name].wait()
        except TimeoutError:
            raise LinkError(f"no {name} from {self.url} for {timeout_s:g} s") from None
        return self._latest.get((name, 0)) or {}

    async def request(self, name: str, instance: int = 0) -> dict[str, Any]:
        """OBJ_REQ: the object's current value straight from the autopilot."""
        definition = self.registry[name]
        await self._transact(MessageType.OBJ_REQ, definition, instance, b"")
        return self._latest[name, instance]

    async def write(self, name: str, values: dict[str, Any], instance: int = 0) -> None:
        """OBJ_ACK: set an object on the autopilot; returns once ACKed, raises on NACK."""
        definition = self.registry[name]
        await self._transact(MessageType.OBJ_ACK, definition, instance, definition.encode(values))

    def send(self, name: str, values: dict[str, Any], instance: int = 0) -> None:
        """OBJ: set an object without waiting for anything."""
        definition = self.registry[name]
        self._send(Frame(MessageType.OBJ, definition.id, instance, definition.encode(values)))

    async def _transact(
        self, kind: MessageType, definition: ObjectDef, instance: int, data: bytes
    ) -> None:
        frame = Frame(kind, definition.id, instance, data)
        key = (kind.name, definition.id, instance)
        async with self._locks[definition.id]:
            for attempt in range(1 + self.retries):
                if not self.connected:
                    raise LinkError(f"UAVTalk link to {self.url} is down; is the autopilot on?")
                future: asyncio.Future[Frame] = asyncio.get_running_loop().create_future()
                self._pending[key] = future
                self._send(frame)
                try:
                    async with asyncio.timeout(self.timeout_s):
                        answer = await future
                except TimeoutError:
                    log.info("%s %s: no answer (try %d)", kind.name, definition.name, attempt + 1)
                    continue
                finally:
                    self._pending.pop(key, None)
                if answer.type is MessageType.NACK:
                    raise Refused(self._refusal(definition, kind))
                return
        raise LinkError(
            f"{definition.name}: no answer from {self.url} to {kind.name} after"
            f" {1 + self.retries} tries of {self.timeout_s:g} s"
        )

    def _refusal(self, definition: ObjectDef, kind: MessageType) -> str:
        status = self._latest.get((STATUS_OBJECT, 0))
        if status and status.get("ObjectID") == definition.id and status["Result"] == "Refused":
            return bytes(status["Reason"]).rstrip(b"\0").decode("ascii", "replace")
        if kind is MessageType.OBJ_REQ:
            return f"the autopilot does not know the object {definition.name}"
        return f"the autopilot refused the {definition.name} update"

    def _send(self, frame: Frame) -> None:
        writer = self._writer
        if writer is None or writer.is_closing():
            return
        multi = self.registry.multi_instance(frame.object_id)
        writer.write(encode_frame(frame, multi_instance=multi))
