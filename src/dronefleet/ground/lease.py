"""Which ground replica runs the Mission Planner (docs/DESIGN.md §13, issue 27): a lease in the
shared PostgreSQL state, not a consensus of our own.

One row per lease: its holder and when it expires, on the database server's clock (the replicas'
clocks never meet). Every :data:`RENEW_S` each replica runs one statement that takes the row if
it is free or expired, or extends it if it is its own, and returns the holder: the database's
row lock decides between two replicas asking at once. A leader that dies stops renewing and a
standby takes the lease at most :data:`LEASE_S` + :data:`RENEW_S` after the last renewal.

A leader stops acting before its lease can have passed to another: it counts the lease from
*before* it asked (its own monotonic clock), less :data:`GUARD_S` for stopping, and steps down
once that time passes without a renewal — when the database is lost, or slow. A replica stopped
cleanly gives the lease back at once.

``on_lead`` and ``on_follow`` are awaited one at a time, in order, on a task of their own so that
renewing never waits for the planner to start; a lease lost while ``on_lead`` is still running
cancels it before ``on_follow`` runs.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable, Coroutine
from typing import Any

from dronefleet import clock
from dronefleet.errors import Unavailable
from dronefleet.ground.state import StateStore

log = logging.getLogger(__name__)

#: Seconds a lease lasts from its last renewal.
LEASE_S = 3.5
#: Seconds between a replica's claims (renewals for the leader, tries for a standby): a leader
#: on a loaded host has ``LEASE_S - GUARD_S`` seconds, six tries, to get one through.
RENEW_S = 0.5
#: Seconds before its lease may end that a leader stops acting.
GUARD_S = 0.5

_SCHEMA = """
CREATE TABLE IF NOT EXISTS ground_leases (
    name TEXT PRIMARY KEY,
    holder TEXT NOT NULL,
    expires_at TIMESTAMPTZ NOT NULL
);
"""
_CLAIM = (
    "INSERT INTO ground_leases (name, holder, expires_at) "
    "VALUES (?, ?, clock_timestamp() + make_interval(secs => ?)) "
    "ON CONFLICT (name) DO UPDATE SET holder = excluded.holder, expires_at = excluded.expires_at "
    "WHERE ground_leases.holder = excluded.holder OR ground_leases.expires_at < clock_timestamp() "
    "RETURNING holder"
)
_HOLDER = "SELECT holder FROM ground_leases WHERE name = ? AND expires_at > clock_timestamp()"
_RELEASE = "DELETE FROM ground_leases WHERE name = ? AND holder = ?"

Step = Callable[[], Coroutine[Any, Any, None]]


class Lease:
    """``await Lease(state, holder=..., on_lead=..., on_follow=...).start()``."""

    def __init__(
        self,
        state: StateStore,
        *,
        holder: str,
        on_lead: Step,
        on_follow: Step,
        name: str = "mission-planner",
        lease_s: float = LEASE_S,
        renew_s: float = RENEW_S,
        guard_s: float = GUARD_S,
    ) -> None:
        if not lease_s > renew_s + guard_s:
            raise ValueError("a lease must outlast a renewal interval and the guard")
        self.state = state
        self.holder = holder
        self.name = name
        self.lease_s, self.renew_s, self.guard_s = lease_s, renew_s, guard_s
        self._on_lead, self._on_follow = on_lead, on_follow
        #: Whether this replica holds the lease now (and may act on it until ``valid_until``).
        self.held = False
        self.valid_until = 0.0
        #: Whether ``on_lead`` has run (and ``on_follow`` not since): the planner is running.
        self.leading = False
        self.error: str | None = None  # the last claim's failure, None after one that worked
        self._wanted = asyncio.Event()
        self._renewer: asyncio.Task[None] | None = None
        self._follower: asyncio.Task[None] | None = None
        self._stepping: asyncio.Task[None] | None = None

    async def start(self) -> Lease:
        await self.state.script(_SCHEMA)
        await self._claim_once()
        self._follower = asyncio.create_task(self._follow(), name="lease:follow")
        self._renewer = asyncio.create_task(self._renew(), name="lease:renew")
        return self

    async def stop(self) -> None:
        """Stop leading (if it was) and give the lease back for a standby to take at once."""
        for task in (self._renewer, self._follower):
            if task is not None:
                task.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await task
        self._renewer = self._follower = None
        if self._stepping is not None:
            self._stepping.cancel()
            await asyncio.wait({self._stepping})
            self._stepping = None
        was_held, self.held = self.held, False
        if self.leading:
            await self._stand_down()
        if was_held:
            with contextlib.suppress(Exception):
                await self.state.write((_RELEASE, (self.name, self.holder)))

    async def leader(self) -> str | None:
        """The replica that holds the lease now, as the database says, or None."""
        rows = await self.state.rows(_HOLDER, (self.name,))
        return rows[0][0] if rows else None

    # -- renewing ---------------------------------------------------------------------------
    async def _renew(self) -> None:
        while True:
            await asyncio.sleep(self.renew_s)
            await self._claim_once()

    async def _claim_once(self) -> None:
        asked = clock.monotonic()
        # A slow answer still counts while the lease it renews lasts (counted from the asking).
        wait = self.valid_until - asked if self.held else self.lease_s
        try:
            async with asyncio.timeout(max(wait, self.renew_s)):
                rows = await self.state.rows(_CLAIM, (self.name, self.holder, self.lease_s))
        except (TimeoutError, OSError, Unavailable) as exc:
            self.error = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
            if self.held and clock.monotonic() >= self.valid_until:
                log.warning("lease %s not renewed in time (%s): stepping down", self.name, exc)
                self._set(False)
            return
        self.error = None
        if rows:
            self.valid_until = asked + self.lease_s - self.guard_s
            self._set(True)
        else:
            self._set(False)

    def _set(self, held: bool) -> None:
        if held != self.held:
            log.info("%s the %s lease", "took" if held else "lost", self.name)
        self.held = held
        if not held and self._stepping is not None:
            self._stepping.cancel()  # a planner still starting stops at once
        self._wanted.set()

    def acting(self) -> bool:
        """Whether this replica may act as the leader at this instant (a check for callers who
        would act on their own: the lease held and not past its time)."""
        return self.held and clock.monotonic() < self.valid_until

    # -- following the lease: the planner starts and stops -----------------------------------
    async def _follow(self) -> None:
        watchdog = asyncio.create_task(self._expire(), name="lease:expire")
        try:
            while True:
                await self._wanted.wait()
                self._wanted.clear()
                await self._step(lead=self.held)
        finally:
            watchdog.cancel()

    async def _expire(self) -> None:
        """Steps down at ``valid_until`` even while a claim is still waiting for the database."""
        while True:
            wait = self.valid_until - clock.monotonic() if self.held else self.renew_s
            await asyncio.sleep(max(0.05, wait))
            if self.held and clock.monotonic() >= self.valid_until:
                log.warning("lease %s ran out before a renewal: stepping down", self.name)
                self._set(False)

    async def _step(self, *, lead: bool) -> None:
        if lead == self.leading:
            return
        if not lead:
            await self._stand_down()
            return
        self.leading = True  # from here on, whatever on_lead started is stopped by on_follow
        step = self._stepping = asyncio.create_task(self._on_lead(), name="lease:lead")
        try:
            await asyncio.wait({step})
        finally:
            if not step.done():
                step.cancel()  # this replica is stopping: stop() waits for it
        self._stepping = None
        if step.cancelled() or step.exception() is not None:
            if not step.cancelled():
                log.error("leading failed to start", exc_info=step.exception())
            await self._stand_down()  # the next claim tries again if the lease is still ours

    async def _stand_down(self) -> None:
        try:
            await self._on_follow()
        except Exception:
            log.exception("stepping down from the %s lease failed", self.name)
        self.leading = False
