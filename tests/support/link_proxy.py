"""A slow, lossy TCP link between a drone's bridge and the ground broker, for the fault tests.

The issue's rows ran the bridge through ``tc netem`` (500 ms latency, 30 % loss). This kernel has
no netem qdisc ("Specified qdisc kind is unknown"), and Toxiproxy, the usual user-space tool, is
neither on PyPI nor in Debian; so the link is made here, in the tests only. What it emulates is
what TCP makes of such a link, which is what MQTT sees: every chunk arrives ``latency_s`` after it
was sent, in order, nothing dropped; a chunk "lost" (with probability ``loss``) arrives only after
TCP's retransmission timeout, which doubles while the retransmission is lost too, and everything
behind it waits (head-of-line blocking). The first timeout is one round trip (twice the latency), as
Linux's RTO is for a steady link.
"""

from __future__ import annotations

import asyncio
import contextlib
import random
import threading
import time

from dronefleet.messaging.embedded import free_port


class LinkProxy:
    """``127.0.0.1:port`` forwards to ``127.0.0.1:target_port`` over the emulated link."""

    def __init__(self, target_port: int, *, latency_s: float, loss: float = 0.0, seed: int = 7):
        self.target_port, self.latency_s, self.loss = target_port, latency_s, loss
        self.port = free_port()
        self.random = random.Random(seed)
        self.chunks = 0
        self.retransmitted = 0
        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._loop.run_forever, daemon=True)
        self._server: asyncio.Server | None = None

    def start(self) -> LinkProxy:
        self._thread.start()
        asyncio.run_coroutine_threadsafe(self._listen(), self._loop).result(10)
        return self

    def stop(self) -> None:
        async def close() -> None:
            if self._server is not None:
                self._server.close()
            for task in asyncio.all_tasks():
                if task is not asyncio.current_task():
                    task.cancel()

        with contextlib.suppress(Exception):
            asyncio.run_coroutine_threadsafe(close(), self._loop).result(10)
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(10)

    async def _listen(self) -> None:
        self._server = await asyncio.start_server(self._connection, "127.0.0.1", self.port)

    async def _connection(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter):
        try:
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
                w.close()

    def _delay(self) -> float:
        """Seconds from sending a chunk to its arrival: the latency, plus the retransmission
        timeouts it waits out while lost."""
        self.chunks += 1
        delay, rto = self.latency_s, 2 * self.latency_s
        while self.random.random() < self.loss:
            self.retransmitted += 1
            delay += rto
            rto *= 2
        return delay

    async def _pump(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        queue: asyncio.Queue[tuple[float, bytes]] = asyncio.Queue()

        async def deliver() -> None:
            while True:
                due, data = await queue.get()
                await asyncio.sleep(max(0.0, due - time.monotonic()))
                writer.write(data)
                await writer.drain()

        sender = asyncio.create_task(deliver())
        last_due = 0.0
        try:
            while data := await reader.read(65536):
                last_due = max(last_due, time.monotonic() + self._delay())  # in order
                queue.put_nowait((last_due, data))
            while not queue.empty():
                await asyncio.sleep(0.05)
        finally:
            sender.cancel()
