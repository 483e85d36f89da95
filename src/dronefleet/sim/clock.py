"""The sim clock: vehicle seconds that pass ``speedup`` times faster than wall seconds.

One :class:`SimClock` serves a whole :class:`~dronefleet.sim.world.SimWorld`; it implements the
project's :class:`~dronefleet.clock.Clock` protocol, so drone-side code (Drone Controller, Mission
Worker) runs unchanged on sim time. Time only moves when the world loop (or a test) calls
:meth:`SimClock.advance`; sleepers are woken in deadline order as their deadline passes.
"""

from __future__ import annotations

import asyncio
import heapq
import itertools

#: Tolerance for float drift of accumulated steps (0.05 * 6 != 0.3 exactly).
_EPS_S = 1e-9


class SimClock:
    """Vehicle time in seconds, starting at 0; satisfies :class:`dronefleet.clock.Clock`."""

    def __init__(self, speedup: float = 1.0) -> None:
        if not speedup > 0:
            raise ValueError(f"speedup must be positive, got {speedup}")
        self._now = 0.0
        self._speedup = float(speedup)
        self._sleepers: list[tuple[float, int, asyncio.Future[None]]] = []
        self._seq = itertools.count()

    def now(self) -> float:
        return self._now

    @property
    def speedup(self) -> float:
        return self._speedup

    @speedup.setter
    def speedup(self, value: float) -> None:
        if not value > 0:
            raise ValueError(f"speedup must be positive, got {value}")
        self._speedup = float(value)

    @property
    def pending(self) -> int:
        """How many sleepers are waiting (cancelled ones included until their deadline)."""
        return len(self._sleepers)

    def next_deadline(self) -> float | None:
        return self._sleepers[0][0] if self._sleepers else None

    async def sleep(self, duration_s: float) -> None:
        """Wait until ``duration_s`` vehicle seconds have passed (woken by :meth:`advance`)."""
        if duration_s <= 0:
            await asyncio.sleep(0)
            return
        future: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        heapq.heappush(self._sleepers, (self._now + duration_s, next(self._seq), future))
        await future

    def advance(self, dt_s: float) -> int:
        """Move time forward by ``dt_s`` and wake every due sleeper; returns how many woke."""
        if dt_s < 0:
            raise ValueError("time does not run backwards")
        self._now += dt_s
        return self.wake_due()

    def wake_due(self) -> int:
        """Resolve sleepers whose deadline has passed, earliest first (ties in call order)."""
        woken = 0
        limit = self._now + _EPS_S
        while self._sleepers and self._sleepers[0][0] <= limit:
            _, _, future = heapq.heappop(self._sleepers)
            if not future.done():
                future.set_result(None)
                woken += 1
        return woken

    def __repr__(self) -> str:
        return f"SimClock(now={self._now:.3f}s, speedup={self._speedup:g})"
