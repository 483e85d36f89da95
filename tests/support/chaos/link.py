"""A drone's link to the ground's broker whose latency, loss and partitions change while it runs."""

from __future__ import annotations

import asyncio
import contextlib
import time

from support.link_proxy import LinkProxy


class ChaosLink(LinkProxy):
    """A drone's bridge link (support/link_proxy.py's emulation of what TCP makes of latency and
    loss), whose ``latency_s`` and ``loss`` may change while it runs, and which can be
    partitioned: nothing crosses while it is (data waits, as TCP's retransmissions would, and new
    connections are accepted but reach the ground broker only once it heals); a side that gives
    up meanwhile (the bridge's or the broker's keep-alive) aborts both."""

    def __init__(self, target_port: int, seed: int) -> None:
        super().__init__(target_port, latency_s=0.0, loss=0.0, seed=seed)
        self._healed: asyncio.Event | None = None

    def set(self, *, latency_s: float = 0.0, loss: float = 0.0) -> None:
        self.latency_s, self.loss = latency_s, loss

    def partition(self, on: bool) -> None:
        def flip() -> None:
            assert self._healed is not None
            if on:
                self._healed.clear()
            else:
                self._healed.set()

        self._loop.call_soon_threadsafe(flip)

    @property
    def partitioned(self) -> bool:
        return self._healed is not None and not self._healed.is_set()

    async def _listen(self) -> None:
        self._healed = asyncio.Event()
        self._healed.set()
        await super()._listen()

    async def _connection(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter):
        assert self._healed is not None
        try:
            await self._healed.wait()
            up_reader, up_writer = await asyncio.open_connection("127.0.0.1", self.target_port)
        except OSError:
            writer.close()
            return
        pumps = [
            asyncio.create_task(self._pump(reader, up_writer)),
            asyncio.create_task(self._pump(up_reader, writer)),
        ]
        await asyncio.wait(pumps, return_when=asyncio.FIRST_COMPLETED)
        for task in pumps:
            task.cancel()
        for w in (writer, up_writer):
            with contextlib.suppress(Exception):
                if self.partitioned:
                    w.transport.abort()
                else:
                    w.close()

    async def _pump(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        assert self._healed is not None
        healed = self._healed
        queue: asyncio.Queue[tuple[float, bytes]] = asyncio.Queue()

        async def deliver() -> None:
            while True:
                due, data = await queue.get()
                await asyncio.sleep(max(0.0, due - time.monotonic()))
                await healed.wait()
                writer.write(data)
                await writer.drain()

        sender = asyncio.create_task(deliver())
        last_due = 0.0
        try:
            with contextlib.suppress(ConnectionError):
                while data := await reader.read(65536):
                    last_due = max(last_due, time.monotonic() + self._delay())
                    queue.put_nowait((last_due, data))
            while not queue.empty() and not self.partitioned and not sender.done():
                await asyncio.sleep(0.05)
        finally:
            sender.cancel()
