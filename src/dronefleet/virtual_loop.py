"""Virtual time for a whole simulated system in one process (docs/DESIGN.md §4, issue 9).

A :class:`VirtualTimeLoop` is an asyncio event loop whose ``time()`` is virtual: it stands still
while any task is ready to run, any socket has data waiting or any executor job is still working,
and jumps to the next timer only when everything is waiting. Every ``asyncio.sleep``,
``asyncio.timeout``, ``call_later``, broker keep-alive, heartbeat interval and physics step
follows it, so work, broker hops and I/O take zero vehicle seconds and a scenario gives the same
figures whatever the machine's load.

``speedup`` paces virtual time against the wall clock (N virtual seconds per wall second at most);
the loop never runs ahead of the software: when the process is busy, virtual time waits for it.
``speedup=math.inf`` (``--speedup max``) runs as fast as the CPU allows.

Why our own loop and not ``looptime`` (PyPI): looptime fakes and compacts loop time for tests (a
pytest plugin patching loops), but it has no pacing against the wall clock at a finite speed-up —
which the demo needs so a person can watch the drones fly — and it advances time by configured
idle steps while executor jobs run, where we must stand still until they finish. What we need is
one selector wrapper and one ``time()`` override (below); the rest is asyncio's own loop.

Only in-process parts may run on it: a separate process (a real Mosquitto, ArduPilot SITL, a
browser) keeps real time, and at ``speedup=inf`` its answers would arrive "late" in virtual time.
At a finite speed-up their I/O arrives while the loop paces, at the virtual time that matches the
wall clock, which is what the demo needs for its browser and REST clients.
"""

from __future__ import annotations

import argparse
import asyncio
import heapq
import itertools
import math
import selectors
import time
from collections.abc import Awaitable, Callable, Coroutine
from typing import Any, TypeVar

T = TypeVar("T")

#: Falling further behind the paced schedule than this (wall seconds) forgives the debt, so a
#: stall is followed by a paced run, not by a burst that tries to catch up.
MAX_LAG_WALL_S = 0.25
#: While an executor job works, the loop re-checks at this wall interval (virtual time stands).
_BUSY_POLL_WALL_S = 0.05


class _PacedSelector(selectors.BaseSelector):
    """The real selector, asked first without waiting; when nothing is ready, time moves."""

    def __init__(self, loop: VirtualTimeLoop) -> None:
        self._real = selectors.DefaultSelector()
        self._loop = loop

    # -- the part that makes time virtual -------------------------------------------------------
    def select(self, timeout: float | None = None) -> list[tuple[selectors.SelectorKey, int]]:
        loop = self._loop
        events = self._real.select(0)
        if events or timeout == 0:
            pass
        elif loop.busy_jobs:
            # A thread is working for the loop: its result takes zero virtual time.
            wait = _BUSY_POLL_WALL_S if timeout is None else min(timeout, _BUSY_POLL_WALL_S)
            events = self._real.select(_sooner(wait, loop.wall_wait_s()))
        elif timeout is None:
            # No timer at all: only outside I/O (or a wall timer) can wake us.
            events = self._real.select(loop.wall_wait_s())
        else:
            events = loop.advance_paced(timeout, self._real)
        loop.run_wall_timers()
        return events

    # -- delegation -------------------------------------------------------------------------------
    def register(self, fileobj: Any, events: int, data: Any = None) -> selectors.SelectorKey:
        return self._real.register(fileobj, events, data)

    def unregister(self, fileobj: Any) -> selectors.SelectorKey:
        return self._real.unregister(fileobj)

    def modify(self, fileobj: Any, events: int, data: Any = None) -> selectors.SelectorKey:
        return self._real.modify(fileobj, events, data)

    def close(self) -> None:
        self._real.close()

    def get_key(self, fileobj: Any) -> selectors.SelectorKey:
        return self._real.get_key(fileobj)

    def get_map(self) -> Any:
        return self._real.get_map()


class VirtualTimeLoop(asyncio.SelectorEventLoop):
    """An event loop on virtual time, paced at ``speedup`` virtual seconds per wall second."""

    def __init__(self, speedup: float = math.inf) -> None:
        if not speedup > 0:
            raise ValueError(f"speedup must be positive, got {speedup}")
        self._virtual_s = time.monotonic()
        self._epoch_offset_s = time.time() - self._virtual_s
        self._speedup = float(speedup)
        self._anchor_virtual_s = self._virtual_s
        self._anchor_wall_s = time.monotonic()
        self.busy_jobs = 0
        self._wall_timers: list[tuple[float, int, WallTimer]] = []
        self._wall_order = itertools.count()
        super().__init__(_PacedSelector(self))

    # -- time -------------------------------------------------------------------------------------
    def time(self) -> float:
        return self._virtual_s

    def epoch_time(self) -> float:
        """Seconds since the Unix epoch on this loop's clock (for timestamps)."""
        return self._epoch_offset_s + self._virtual_s

    @property
    def speedup(self) -> float:
        return self._speedup

    @speedup.setter
    def speedup(self, value: float) -> None:
        if not value > 0:
            raise ValueError(f"speedup must be positive, got {value}")
        self._speedup = float(value)
        self._rebase()

    def _rebase(self) -> None:
        self._anchor_virtual_s, self._anchor_wall_s = self._virtual_s, time.monotonic()

    def advance_paced(
        self, timeout_s: float, real: selectors.BaseSelector
    ) -> list[tuple[selectors.SelectorKey, int]]:
        """Everything waits: move virtual time by ``timeout_s``, pacing it against the wall.

        Outside I/O that arrives while pacing is served at the virtual time matching the wall
        clock at that moment (never later than the timer that was due)."""
        target = self._virtual_s + timeout_s
        if math.isinf(self._speedup):
            self._virtual_s = target
            return []
        due_wall = self._anchor_wall_s + (target - self._anchor_virtual_s) / self._speedup
        now_wall = time.monotonic()
        if now_wall - due_wall > MAX_LAG_WALL_S:
            self._rebase()  # hopelessly behind (a stall): pace from here, no burst
            due_wall = now_wall
        wall = self.wall_wait_s()
        wait = due_wall - now_wall if wall is None else min(due_wall - now_wall, wall)
        events = real.select(wait) if wait > 0 else []
        if events or now_wall + wait < due_wall:  # woken early: time is where the wall says
            paced = self._anchor_virtual_s + (time.monotonic() - self._anchor_wall_s) * (
                self._speedup
            )
            self._virtual_s = max(self._virtual_s, min(target, paced))
        else:
            self._virtual_s = target
        return events

    # -- wall timers: for what keeps wall time outside the process ------------------------------
    def call_wall_later(self, delay_s: float, callback: Callable[[], object]) -> WallTimer:
        """``callback()`` after ``delay_s`` **wall** seconds, whatever virtual time does: for a
        peer that keeps wall time (a broker closes a link silent for 1.5 keepalives, and virtual
        time may stand still longer than that while a thread works for the loop on a busy
        host). Virtual timers would never fire in such a spell."""
        timer = WallTimer(callback)
        heapq.heappush(
            self._wall_timers, (time.monotonic() + delay_s, next(self._wall_order), timer)
        )
        return timer

    def wall_wait_s(self) -> float | None:
        """Wall seconds until the next wall timer is due (None: there is none)."""
        while self._wall_timers and self._wall_timers[0][2].cancelled:
            heapq.heappop(self._wall_timers)
        if not self._wall_timers:
            return None
        return max(0.0, self._wall_timers[0][0] - time.monotonic())

    def run_wall_timers(self) -> None:
        """Hand the wall timers that are due to the loop (run in this turn, as ready work)."""
        if not self._wall_timers:
            return  # every turn of the loop asks: no clock read without a timer
        now = time.monotonic()
        while self._wall_timers and self._wall_timers[0][0] <= now:
            _, _, timer = heapq.heappop(self._wall_timers)
            if not timer.cancelled:
                self.call_soon(timer.callback)

    # -- executor jobs hold time still ----------------------------------------------------------
    def run_in_executor(  # type: ignore[override]  # same call, typeshed's generic signature
        self, executor: Any, func: Callable[..., T], *args: Any
    ) -> asyncio.Future[T]:
        future = super().run_in_executor(executor, func, *args)
        self.busy_jobs += 1
        future.add_done_callback(self._job_done)
        return future

    def _job_done(self, _: asyncio.Future[Any]) -> None:
        self.busy_jobs -= 1


class WallTimer:
    """A wall timer's handle: ``cancel()`` it."""

    __slots__ = ("callback", "cancelled")

    def __init__(self, callback: Callable[[], object]) -> None:
        self.callback, self.cancelled = callback, False

    def cancel(self) -> None:
        self.cancelled = True


def every_wall_s(interval_s: float, callback: Callable[[], object]) -> WallTimer | None:
    """``callback()`` every ``interval_s`` wall seconds on a :class:`VirtualTimeLoop` (see
    :meth:`VirtualTimeLoop.call_wall_later`) until the handle is cancelled; on any other loop
    None: its timers already keep wall time."""
    loop = asyncio.get_running_loop()
    if not isinstance(loop, VirtualTimeLoop):
        return None
    handle = WallTimer(callback)

    def tick() -> None:
        if handle.cancelled:
            return
        callback()
        loop.call_wall_later(interval_s, tick)

    loop.call_wall_later(interval_s, tick)
    return handle


def _sooner(a: float | None, b: float | None) -> float | None:
    """The shorter of two waits (None: forever)."""
    if a is None:
        return b
    return a if b is None else min(a, b)


async def held(awaitable: Awaitable[T]) -> T:
    """Await work a thread does for the loop that the loop cannot see (aiosqlite's connection
    thread answers through ``call_soon_threadsafe``): on a virtual loop time stands still until
    it is done, as for an executor job, so a disk write takes zero vehicle seconds whatever the
    load. On any other loop it is a plain ``await``."""
    loop = asyncio.get_running_loop()
    if not isinstance(loop, VirtualTimeLoop):
        return await awaitable
    loop.busy_jobs += 1
    try:
        return await awaitable
    finally:
        loop.busy_jobs -= 1


def run(
    main: Coroutine[Any, Any, T] | Callable[[], Coroutine[Any, Any, T]],
    *,
    speedup: float = math.inf,
    debug: bool | None = None,
) -> T:
    """``asyncio.run`` on a :class:`VirtualTimeLoop`: the entry point of in-process simulations."""
    with asyncio.Runner(debug=debug, loop_factory=lambda: VirtualTimeLoop(speedup)) as runner:
        coro = main if isinstance(main, Coroutine) else main()
        return runner.run(coro)


def parse_speedup(text: str) -> float:
    """``--speedup`` values: a positive number, or ``max`` for as fast as the CPU allows."""
    if text.strip().lower() in ("max", "inf"):
        return math.inf
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"--speedup takes a positive number or 'max', not {text!r}") from None
    if not value > 0 or math.isnan(value):
        raise ValueError(f"--speedup must be positive or 'max', not {text!r}")
    return value


def speedup_arg(text: str) -> float:
    """argparse type for ``--speedup``."""
    try:
        return parse_speedup(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
