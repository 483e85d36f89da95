"""One clock for all waiting (docs/DESIGN.md §4).

Drone-side code takes its time from the vehicle it flies: a simulated vehicle's sim clock, or an
autopilot's boot time. Ground code uses the event loop's time. Both implement :class:`Clock`.

In a simulation run in one process the event loop's time is virtual
(:mod:`dronefleet.virtual_loop`), so :func:`monotonic` and :func:`timestamp_s` — which every
component uses instead of ``time.monotonic()`` and ``time.time()`` — follow vehicle seconds, and
logs of a simulated run line up with its vehicles. On an ordinary loop they are the wall clock.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from typing import Protocol, runtime_checkable


@runtime_checkable
class Clock(Protocol):
    """A source of time in seconds and a way to wait on it."""

    def now(self) -> float:
        """Current time in seconds (vehicle seconds for a vehicle clock)."""
        ...

    async def sleep(self, duration_s: float) -> None:
        """Wait ``duration_s`` seconds of this clock's time."""
        ...

    @property
    def speedup(self) -> float:
        """How many of this clock's seconds pass per wall second (1 for real time)."""
        ...


def monotonic() -> float:
    """Seconds on the running event loop's clock (virtual in a simulation), else wall time."""
    try:
        return asyncio.get_running_loop().time()
    except RuntimeError:
        return time.monotonic()


def timestamp_s() -> float:
    """Seconds since the Unix epoch on the running loop's clock: every timestamp a component
    writes (heartbeats, telemetry, progress, audit, logs) comes from here."""
    try:
        loop = asyncio.get_running_loop()
    except RuntimeError:
        return time.time()
    epoch_time = getattr(loop, "epoch_time", None)
    return epoch_time() if epoch_time is not None else time.time()


class WallClock:
    """The event loop's time (wall time on an ordinary loop, virtual in a simulation)."""

    speedup = 1.0

    def now(self) -> float:
        return monotonic()

    async def sleep(self, duration_s: float) -> None:
        await asyncio.sleep(max(0.0, duration_s))


async def wait_until(
    clock: Clock,
    predicate: Callable[[], object],
    *,
    poll_s: float = 0.1,
    timeout_s: float | None = None,
) -> bool:
    """Poll ``predicate`` on ``clock`` until it is true; return False on timeout (clock seconds)."""
    deadline = None if timeout_s is None else clock.now() + timeout_s
    while not predicate():
        if deadline is not None and clock.now() >= deadline:
            return False
        await clock.sleep(poll_s)
    return True


async def sleep_on_estimate(clock: Clock, duration_s: float, max_wall_nap_s: float) -> None:
    """Sleep ``duration_s`` of a clock that is estimated from a remote one (an autopilot's).

    The wall naps are sized by the clock's current speed-up and capped, so a rate that changes
    (a sped-up simulator slowing under load) is followed and the deadline is not overslept.
    """
    if duration_s <= 0:
        await asyncio.sleep(0)
        return
    deadline = clock.now() + duration_s
    while (left := deadline - clock.now()) > 0:
        await asyncio.sleep(min(max(left / max(clock.speedup, 1e-3), 0.0005), max_wall_nap_s))
