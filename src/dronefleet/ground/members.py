"""Which ground replicas are alive (issue 27): a row each in the shared PostgreSQL state.

Replicas that share the fleet by drone (ground/partition.py) must agree on who shares it. As for
the Mission Planner's lease (ground/lease.py), the database decides, not a consensus of our own:
every :data:`RENEW_S` each replica runs one statement that extends its own row's expiry (on the
database server's clock, :data:`TTL_S` ahead) and returns every replica whose row has not
expired. A replica that dies stops renewing and drops out of every other's view at most
:data:`TTL_S` + :data:`RENEW_S` later; one stopped cleanly deletes its row at once.

While the database does not answer, a replica keeps the members it last saw: it may then take
telemetry another also takes (stored twice), never leave a drone's untaken because it guessed.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable

from dronefleet.errors import Unavailable
from dronefleet.ground.state import StateStore

log = logging.getLogger(__name__)

#: Seconds a replica's row lasts from its last renewal (the Mission Planner's lease's length).
TTL_S = 3.5
#: Seconds between renewals.
RENEW_S = 0.5

_SCHEMA = """
CREATE TABLE IF NOT EXISTS ground_members (
    name TEXT PRIMARY KEY,
    expires_at TIMESTAMPTZ NOT NULL
);
"""
# The inserted row is not visible to the same statement's SELECT: the UNION adds it.
_RENEW = (
    "WITH me AS (INSERT INTO ground_members (name, expires_at) "
    "VALUES (?, clock_timestamp() + make_interval(secs => ?)) "
    "ON CONFLICT (name) DO UPDATE SET expires_at = excluded.expires_at RETURNING name) "
    "SELECT name FROM ground_members WHERE expires_at > clock_timestamp() "
    "UNION SELECT name FROM me"
)
_LEAVE = "DELETE FROM ground_members WHERE name = ?"
#: Rows of replicas long gone, cleared now and then.
_FORGET = "DELETE FROM ground_members WHERE expires_at < clock_timestamp() - interval '1 hour'"


class Membership:
    """``await Membership(state, name=..., on_change=...).start()``: ``members`` is the sorted
    names of the live replicas, this one included; ``on_change(members)`` is called when it
    changes."""

    def __init__(
        self,
        state: StateStore,
        *,
        name: str,
        on_change: Callable[[tuple[str, ...]], None],
        ttl_s: float = TTL_S,
        renew_s: float = RENEW_S,
    ) -> None:
        if not ttl_s > 2 * renew_s:
            raise ValueError("a member's row must outlast two renewals")
        self.state, self.name = state, name
        self.ttl_s, self.renew_s = ttl_s, renew_s
        self._on_change = on_change
        self.members: tuple[str, ...] = (name,)
        self.error: str | None = None  # the last renewal's failure; None after one that worked
        self._task: asyncio.Task[None] | None = None

    async def start(self) -> Membership:
        await self.state.script(_SCHEMA)
        with contextlib.suppress(Exception):
            await self.state.write((_FORGET, ()))
        await self.renew()
        self._task = asyncio.create_task(self._renewing(), name="members:renew")
        return self

    async def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
            self._task = None
        with contextlib.suppress(Exception):
            await self.state.write((_LEAVE, (self.name,)))

    async def _renewing(self) -> None:
        while True:
            await asyncio.sleep(self.renew_s)
            await self.renew()

    async def renew(self) -> None:
        """Extend this replica's row and read who is alive (kept as it was on a failure)."""
        try:
            async with asyncio.timeout(self.ttl_s):
                rows = await self.state.rows(_RENEW, (self.name, self.ttl_s))
        except (TimeoutError, OSError, Unavailable) as exc:
            if self.error is None:
                log.warning("replica membership not renewed (%s): keeping %d members as seen",
                            exc or type(exc).__name__, len(self.members))  # fmt: skip
            self.error = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
            return
        self.error = None
        members = tuple(sorted({row[0] for row in rows} | {self.name}))
        if members != self.members:
            gone = sorted(set(self.members) - set(members))
            log.log(logging.WARNING if gone else logging.INFO, "ground replicas: %d (%s)%s",
                    len(members), ", ".join(members),
                    f"; gone: {', '.join(gone)}" if gone else "")  # fmt: skip
            self.members = members
            self._on_change(members)
