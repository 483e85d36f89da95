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

The budget is the worker's **CPU** seconds, not wall seconds: the worker runs at a lower
priority, so beside two busy loops a plan of 2 CPU seconds took over 10 wall seconds and was
refused as "too complex" (a refusal that moved with load). A watcher thread in the worker
stops the job when its CPU time passes the budget; pebble's wall timeout stays as a backstop
(:data:`WALL_FACTOR` times the budget, two minutes at least) for a job that hangs without using CPU.

``processes=0`` runs the work inline instead: the experiments run the ground on virtual time
(docs/DESIGN.md §4), where planning must take no vehicle time at all.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import concurrent.futures.process
import multiprocessing
import os
import signal
import threading
import time
from collections.abc import Callable
from typing import Any, TypeVar

from pebble import ProcessPool

from dronefleet.errors import DronefleetError, InvalidInput

T = TypeVar("T")

#: CPU seconds a planning request may take.
DEFAULT_BUDGET_S = 10.0
#: A job still not done after this many times its budget in wall seconds (and at least
#: :data:`MIN_WALL_S`) is stopped anyway: a backstop for a job that hangs, not a budget.
WALL_FACTOR = 12.0
MIN_WALL_S = 120.0
#: Seconds between the watcher's looks at the job's CPU time, and between its stops of a job
#: over budget.
WATCH_S = 0.02
REPEAT_S = 0.2


def _lower_priority() -> None:
    os.nice(10)


class OverBudget(DronefleetError):
    """A job used more CPU than its budget (raised in the worker, crosses back pickled)."""


def _within_cpu(function: Callable[..., T], args: tuple[Any, ...], budget_s: float) -> T:
    """``function(*args)`` in this worker, interrupted once it has used ``budget_s`` CPU s.

    The watcher sends this process SIGUSR1, whose handler raises :class:`OverBudget` in the
    main thread, where the job runs (pebble's workers ignore SIGINT, so ``interrupt_main`` would
    do nothing; RLIMIT_CPU counts whole seconds only)."""
    start = time.process_time()
    done = threading.Event()

    def over_budget(_signum: int, _frame: Any) -> None:
        if not done.is_set():
            raise OverBudget(f"over {budget_s:g} CPU s")

    def watch() -> None:
        while not done.wait(WATCH_S):
            if time.process_time() - start > budget_s:
                # Again until the job ends: planning code that catches Exception to try
                # another way gets its OverBudget once more.
                os.kill(os.getpid(), signal.SIGUSR1)
                done.wait(REPEAT_S)

    before = signal.signal(signal.SIGUSR1, over_budget)
    watcher = threading.Thread(target=watch, name="cpu-budget", daemon=True)
    watcher.start()
    try:
        return function(*args)
    finally:
        done.set()
        watcher.join()
        signal.signal(signal.SIGUSR1, before)


def _import(modules: tuple[str, ...]) -> None:
    import importlib

    for name in modules:
        importlib.import_module(name)


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

    def warm(self, *modules: str) -> None:
        """Start the worker now and import ``modules`` in it, not waited for: the first plan
        used to pay for both (a spawned Python at nice 10 importing numpy and the planner: over
        30 wall seconds on a loaded host, and the first mission request timed out)."""
        if self.processes > 0 and modules:
            self._ensure_pool().schedule(_import, args=(modules,), timeout=MIN_WALL_S)

    async def run(self, function: Callable[..., T], *args: Any) -> T:
        """``function(*args)`` in a worker (module-level function, picklable arguments)."""
        if self.processes <= 0:
            return function(*args)
        job = (function, args, self.budget_s)
        wall_s = max(self.budget_s * WALL_FACTOR, MIN_WALL_S)
        try:
            future = self._ensure_pool().schedule(_within_cpu, args=job, timeout=wall_s)
        except RuntimeError:  # pebble: "Unexpected error within the Pool"; a new one serves
            self._discard_pool()
            future = self._ensure_pool().schedule(_within_cpu, args=job, timeout=wall_s)
        try:
            # Waited for by an executor thread, so a virtual-time loop knows work is in flight.
            return await asyncio.get_running_loop().run_in_executor(None, future.result)
        except concurrent.futures.process.BrokenProcessPool:
            # A result or an error that could not cross back (issue 26: an unpicklable error
            # broke the pool, and the ground planned nothing more): the next job gets a new one.
            self._discard_pool()
            raise
        except (OverBudget, concurrent.futures.TimeoutError):
            raise InvalidInput(
                f"too complex to plan within {self.budget_s:g} s: try a fixed angle "
                "(area.angle_deg), a larger spacing, or simplify the polygon"
            ) from None
        except asyncio.CancelledError:
            future.cancel()  # stops its worker
            raise

    def _discard_pool(self) -> None:
        pool, self._pool = self._pool, None
        if pool is not None:
            pool.stop()  # its threads and workers go; not waited for here

    def close(self) -> None:
        if self._pool is not None:
            self._pool.stop()
            self._pool.join(timeout=5)
            self._pool = None
