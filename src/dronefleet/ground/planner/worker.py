"""Planning off the event loop, with a time budget (issue 11).

Coverage planning, the split among drones and the estimates are CPU work. Run on the ground's
event loop, a 2000-vertex outline once froze the server for 17 s: every drone was marked lost
and the broker dropped 26,051 messages. Here they run in a worker process, and a request that
needs more than its budget is refused with a 422 that says what to do, and its worker is
stopped rather than left running for minutes.

Why pebble: the standard library's ProcessPoolExecutor cannot stop a job that is running (a
timeout only stops the wait); pebble's ProcessPool terminates and replaces the worker of a job
whose timeout expires or whose future is cancelled, which is exactly the budget wanted here.
Workers start by "spawn" (a fork of a process with broker and HTTP threads is not safe) and run
at a lower priority, so the event loop that serves drones and HTTP is never starved by them.

``processes=0`` runs the work inline instead: the experiments run the ground on virtual time
(docs/DESIGN.md §4), where planning must take no vehicle time at all.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import multiprocessing
import os
from collections.abc import Callable
from typing import Any, TypeVar

from pebble import ProcessPool

from dronefleet.errors import InvalidInput

T = TypeVar("T")

#: Wall seconds a planning request may take.
DEFAULT_BUDGET_S = 10.0


def _lower_priority() -> None:
    os.nice(10)


class PlanningWorker:
    def __init__(self, *, processes: int = 1, budget_s: float = DEFAULT_BUDGET_S) -> None:
        self.processes = processes
        self.budget_s = budget_s
        self._pool: ProcessPool | None = None

    def _ensure_pool(self) -> ProcessPool:
        if self._pool is None:
            self._pool = ProcessPool(
                max_workers=self.processes,
                initializer=_lower_priority,
                context=multiprocessing.get_context("spawn"),
            )
        return self._pool

    async def run(self, function: Callable[..., T], *args: Any) -> T:
        """``function(*args)`` in a worker (module-level function, picklable arguments)."""
        if self.processes <= 0:
            return function(*args)
        future = self._ensure_pool().schedule(function, args=args, timeout=self.budget_s)
        try:
            # Waited for by an executor thread, so a virtual-time loop knows work is in flight.
            return await asyncio.get_running_loop().run_in_executor(None, future.result)
        except concurrent.futures.TimeoutError:
            raise InvalidInput(
                f"too complex to plan within {self.budget_s:g} s: try a fixed angle "
                "(area.angle_deg), a larger spacing, or simplify the polygon"
            ) from None
        except asyncio.CancelledError:
            future.cancel()  # stops its worker
            raise

    def close(self) -> None:
        if self._pool is not None:
            self._pool.stop()
            self._pool.join(timeout=5)
            self._pool = None
