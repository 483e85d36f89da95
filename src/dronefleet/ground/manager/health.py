"""The ground's health (issue 26, item 7): ``GET /api/v1/health`` tells the truth.

It answered ``ok`` whatever happened: with the disk under the ground's state full, with the
broker gone, with the planner's tasks dead. Now each of these is a *problem* with a reason, the
answer is ``503 {"status": "degraded", "problems": [{"what": ..., "detail": ...}]}`` while one
lasts, and ``200 {"status": "ok"}`` again once it is over (nothing to clear by hand):

* **disk**: less than :data:`MIN_FREE_BYTES` free on a disk the ground writes to (its state
  database, the SQLite telemetry store, the pictures), or a write that failed there for want of
  space within :data:`RECENT_S` (SQLite's "database or disk is full", ``ENOSPC``);
* **broker**: a ground service's broker connection is down (each reconnects by itself);
* **planner**: a Mission Planner background task died with an exception, or the planner logged
  a failure, within :data:`RECENT_S`;
* **state**: the ground's state database (PostgreSQL, shared by replicas) does not answer; a
  replica leading the Mission Planner stops it then (ground/lease.py);
* **telemetry**: points wait to be written longer than :data:`BACKLOG_MAX_AGE_S` or more than
  :data:`BACKLOG_MAX_POINTS` of them (the store is slow or failing: its last error is said).

The details name no path or credential: the endpoint is open, as a load balancer's probe is.
The web app polls it and shows a banner while it is not ok (web/js/health.js).
"""

from __future__ import annotations

import asyncio
import errno
import logging
import shutil
import time
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dronefleet import clock
from dronefleet.ground.manager.schemas import HealthProblem as Problem

#: Less free space than this on a disk the ground writes to is a problem (bytes).
MIN_FREE_BYTES = 64 * 1024 * 1024
#: A failure (a full disk on write, a planner task that died) counts this long (seconds).
RECENT_S = 60.0
#: Telemetry waiting to be written longer than this (seconds) is a backlog.
BACKLOG_MAX_AGE_S = 10.0
#: ... or more points than this.
BACKLOG_MAX_POINTS = 20_000
#: Words of a write that failed for want of space (SQLite, the OS).
_FULL = ("database or disk is full", "no space left on device", "disk quota exceeded")


def free_bytes(path: Path) -> int:
    """Free bytes for an unprivileged writer on the disk holding ``path`` (the nearest existing
    folder of it). The probe the tests replace to fake a full disk."""
    here = path
    while not here.exists() and here != here.parent:
        here = here.parent
    return shutil.disk_usage(here).free


def _disk_full(text: str) -> bool:
    lowered = text.lower()
    return any(words in lowered for words in _FULL) or f"[errno {errno.ENOSPC}]" in lowered


class RecentErrors(logging.Handler):
    """The ground's ERROR log records (the last 50, on the wall clock: an operator's "recent"):
    planner tasks that died, a full disk on a write. Attached once to ``dronefleet.ground``."""

    def __init__(self) -> None:
        super().__init__(logging.ERROR)
        self.records: deque[tuple[float, str, str]] = deque(maxlen=50)

    def emit(self, record: logging.LogRecord) -> None:
        try:
            text = record.getMessage()
            if record.exc_info and record.exc_info[1] is not None:
                exc = record.exc_info[1]
                text = f"{text}: {type(exc).__name__}: {exc}"
            self.records.append((time.monotonic(), record.name, text))
        except Exception:  # a log handler never raises
            self.handleError(record)

    def since(self, when: float) -> list[tuple[str, str]]:
        return [(name, text) for at, name, text in self.records if at >= when]


RECENT = RecentErrors()
logging.getLogger("dronefleet.ground").addHandler(RECENT)


@dataclass
class GroundHealth:
    """What the health endpoint looks at, given by the ground services (ground/services.py)."""

    #: A name for each broker connection, and the object with its ``connected``.
    clients: dict[str, Any]
    #: What the ground writes where: a name (state, telemetry, photos) and a path.
    disks: dict[str, Path]
    connector: Any = None  # the telemetry connector: its backlog and last write error
    planner: Any = None  # the Mission Planner: its background tasks
    state: Any = None  # the state store: its ``problem()`` (a database server that is lost)
    min_free_bytes: int = MIN_FREE_BYTES
    #: Tests fake a full disk by replacing this.
    free: Callable[[Path], int] = free_bytes
    #: Errors logged before (another ground's, in one process) are not this ground's.
    started: float = field(default_factory=time.monotonic)

    @classmethod
    def of(cls, services: Any) -> GroundHealth:
        """The health of a :class:`~dronefleet.ground.services.GroundServices` (started)."""
        named = {
            "identifier": services.identifier,
            "telemetry": services.connector,
            "commands": services.gateway,
            "stream": services.hub,
            "planner": services.planner,
            "separation": services.separation,
            "photos": services.photo_collector,
        }
        clients = {name: s.client for name, s in named.items() if s is not None}
        shared_ingest = getattr(services, "shared_ingest", None)  # its own link, over NATS
        if shared_ingest is not None:
            clients["shared ingestion (NATS)"] = shared_ingest
        disks = {"state": Path(services.state_path)}
        store_path = getattr(services.telemetry, "path", None)
        if isinstance(store_path, str) and store_path != ":memory:":
            disks["telemetry"] = Path(store_path)
        disks["photos"] = Path(services.photo_dir)
        shared = getattr(services.state, "shared", False)
        if shared:
            del disks["state"]  # not on this host's disk
        return cls(clients, disks, services.connector, services.planner, services.state)

    async def problems(self) -> list[Problem]:
        found = [*await self._disk(), *self._broker(), *self._planner(), *self._telemetry()]
        return [*await self._state(), *found]

    def _since(self) -> float:
        return max(time.monotonic() - RECENT_S, self.started)

    # -- each kind -----------------------------------------------------------------------------
    async def _disk(self) -> list[Problem]:
        problems = []
        low: dict[int, list[str]] = {}  # free bytes -> what is there: one line per disk
        for name, path in self.disks.items():
            try:
                free = await asyncio.to_thread(self.free, path)
            except OSError as exc:
                problems.append(Problem(what="disk", detail=f"the {name} disk: {exc.strerror}"))
                continue
            if free < self.min_free_bytes:
                low.setdefault(free, []).append(name)
        for free, names in low.items():
            detail = (
                f"{_mb(free)} free on the disk of the ground's {', '.join(names)} "
                f"(below {_mb(self.min_free_bytes)})"
            )
            problems.append(Problem(what="disk", detail=detail))
        error = getattr(self.connector, "write_error", None)
        written: list[str] = []
        if error is not None and error[0] >= clock.monotonic() - RECENT_S and _disk_full(error[1]):
            written.append(f"writing telemetry failed: {error[1]}")
        written += [text for _, text in RECENT.since(self._since()) if _disk_full(text)]
        if written:
            problems.append(Problem(what="disk", detail=_latest(written, "write(s) failed")))
        return problems

    async def _state(self) -> list[Problem]:
        problem = getattr(self.state, "problem", None)
        why = await problem() if problem is not None else None
        return [Problem(what="state", detail=why)] if why else []

    def _broker(self) -> list[Problem]:
        down = [name for name, client in self.clients.items() if not client.connected]
        if not down:
            return []
        detail = f"not connected to the broker: {', '.join(down)} (reconnecting)"
        return [Problem(what="broker", detail=detail)]

    def _planner(self) -> list[Problem]:
        problems = []
        flusher = getattr(self.planner, "_flusher", None)  # its one long-lived task
        died = (
            flusher.exception()
            if isinstance(flusher, asyncio.Task) and flusher.done() and not flusher.cancelled()
            else None
        )
        if died is not None:
            why = f"{type(died).__name__}: {died}"
            problems.append(Problem(what="planner", detail=f"its path writer died: {why}"))
        failed = [
            text
            for name, text in RECENT.since(self._since())
            if name.startswith("dronefleet.ground.planner") and not _disk_full(text)
        ]
        if failed:
            problems.append(Problem(what="planner", detail=_latest(failed, "failure(s)")))
        return problems

    def _telemetry(self) -> list[Problem]:
        connector = self.connector
        if connector is None:
            return []
        pending = int(getattr(connector, "pending", 0))
        since = getattr(connector, "pending_since", None)
        age = clock.monotonic() - since if since is not None and pending else 0.0
        if pending <= BACKLOG_MAX_POINTS and age <= BACKLOG_MAX_AGE_S:
            return []
        error = getattr(connector, "write_error", None)
        why = f"; the store's last error: {error[1]}" if error is not None else ""
        detail = f"{pending} points not yet written, the oldest for {age:.0f} s{why}"
        return [Problem(what="telemetry", detail=detail)]


def _mb(n: int) -> str:
    return f"{n / 1024 / 1024:.1f} MB"


def _latest(texts: Iterable[str], what: str) -> str:
    texts = list(texts)
    more = f" ({len(texts)} {what} in the last {RECENT_S:g} s)" if len(texts) > 1 else ""
    return f"{texts[-1]}{more}"
