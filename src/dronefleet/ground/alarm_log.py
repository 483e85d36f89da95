"""The alarm log (issue 29): every alarm the ground hears, kept, and who acknowledged it.

Alarms come from the drones on ``<id>/alarms/out`` (the fail-safe's battery levels, a sensor
reading out of bounds, a mission's ``virtualalarm`` step; seed 3.3.2.5) and from the ground's own
separation monitor. The Mission Planner acts on them (replacement, collaboration); the operator
saw an 8 s toast and nothing after. Here each one is written to the ground state store
(docs/DESIGN.md §7), so the web's alarm centre lists them after a reload and a ground restart,
filtered by drone, level and time, and an operator acknowledges them (who and when is kept, and
the acknowledgement is audited by the Drone Manager).

The log does not listen on the broker itself: the Mission Planner has already received, decoded
and checked each drone alarm (a forged one, about another drone than its topic's, is dropped
there) and hands it on as an ``alarm`` event; the separation monitor hands on its own. A copy
delivered again after a reconnect is one alarm (a unique fingerprint of what the drone sent).
Writes are queued and batched on a task of their own, bounded: a drone flooding its alarm topic
costs the others nothing but the flood's own rows, counted when dropped.
"""

from __future__ import annotations

import asyncio
import contextlib
import hashlib
import logging
from dataclasses import dataclass
from typing import Any

import orjson

from dronefleet.clock import timestamp_s
from dronefleet.errors import Conflict, NotFound
from dronefleet.ground.state import StateStore

log = logging.getLogger(__name__)

_SCHEMA = """
CREATE TABLE IF NOT EXISTS alarms (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    received_at REAL NOT NULL,
    drone_id TEXT NOT NULL,
    level TEXT NOT NULL,
    source TEXT NOT NULL,
    mission_id TEXT,
    alarm TEXT NOT NULL,
    fingerprint TEXT NOT NULL UNIQUE,
    acked_at REAL,
    acked_by TEXT
);
CREATE INDEX IF NOT EXISTS alarms_drone ON alarms (drone_id, id);
CREATE INDEX IF NOT EXISTS alarms_open ON alarms (acked_at, id);
"""

#: Alarms waiting to be written; past this a flood's newest are dropped (and counted).
QUEUE_SIZE = 10_000
#: Rows kept: past this the oldest acknowledged alarms go first, then the oldest of all.
MAX_ROWS = 200_000
#: Seconds a stop waits for the queued alarms to be written.
STOP_FLUSH_S = 2.0
#: Alarms written in one transaction at most.
BATCH = 500

_COLUMNS = "id, received_at, drone_id, level, source, mission_id, alarm, acked_at, acked_by"


class AlarmSource:
    DRONE = "drone"  # the drone's own alarms/out
    SEPARATION = "separation"  # the ground's separation monitor, about two drones


@dataclass(frozen=True, slots=True)
class AlarmFilter:
    """What ``GET /api/v1/alarms`` asks for; every field optional."""

    drone_id: str | None = None
    level: str | None = None
    since: float | None = None  # received at or after (Unix seconds)
    until: float | None = None  # received at or before
    acknowledged: bool | None = None
    before_id: int | None = None  # paging: only alarms older than this one

    def where(self) -> tuple[str, list[Any]]:
        clauses: list[str] = []
        args: list[Any] = []
        for clause, value in (
            ("drone_id = ?", self.drone_id),
            ("level = ?", self.level),
            ("received_at >= ?", self.since),
            ("received_at <= ?", self.until),
            ("id < ?", self.before_id),
        ):
            if value is not None:
                clauses.append(clause)
                args.append(value)
        if self.acknowledged is not None:
            clauses.append("acked_at IS NOT NULL" if self.acknowledged else "acked_at IS NULL")
        return (" WHERE " + " AND ".join(clauses) if clauses else ""), args


def fingerprint(source: str, alarm: dict[str, Any]) -> str:
    """The same alarm delivered twice has the same fingerprint (what the sender stamped)."""
    key = [
        source,
        alarm.get("drone_id"),
        alarm.get("level"),
        alarm.get("vehicle_time_s"),
        alarm.get("timestamp"),
        alarm.get("message"),
    ]
    return hashlib.sha256(orjson.dumps(key, default=str)).hexdigest()[:32]


def _entry(row: Any) -> dict[str, Any]:
    id_, received_at, drone_id, level, source, mission_id, alarm, acked_at, acked_by = row
    sent = orjson.loads(alarm)
    return {
        "id": id_,
        "received_at": received_at,
        "drone_id": drone_id,
        "level": level,
        "source": source,
        "message": sent.get("message", ""),
        "mission_id": mission_id,
        "step_index": sent.get("step_index"),
        "position": sent.get("position"),
        "reading": sent.get("reading"),
        "virtual": bool(sent.get("virtual", False)),
        "raised_at": sent.get("timestamp"),
        "vehicle_time_s": sent.get("vehicle_time_s"),
        "acknowledged": acked_at is not None,
        "acked_at": acked_at,
        "acked_by": acked_by,
    }


class AlarmLog:
    """``await AlarmLog(state).start()``; feed it with :meth:`on_planner_event` and
    :meth:`on_separation_alarm`; read with :meth:`query`; acknowledge with :meth:`acknowledge`."""

    def __init__(self, state: StateStore, *, max_rows: int = MAX_ROWS) -> None:
        self.state = state
        self.max_rows = max_rows
        self.dropped = 0  # alarms not logged: the queue was full
        self._queue: asyncio.Queue[tuple[float, str, dict[str, Any]]] = asyncio.Queue(QUEUE_SIZE)
        self._writer: asyncio.Task[None] | None = None

    async def start(self) -> AlarmLog:
        await self.state.script(_SCHEMA)
        self._writer = asyncio.create_task(self._write_forever(), name="ground:alarm-log")
        return self

    async def stop(self) -> None:
        if self._writer is None:
            return
        # What is queued is written first, within a bound (a stuck disk must not hold the stop).
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(STOP_FLUSH_S):
                await self.flush()
        self._writer.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await self._writer
        self._writer = None

    # -- in ----------------------------------------------------------------------------------
    def on_planner_event(self, event: str, data: dict[str, Any]) -> None:
        """The Mission Planner's listener: its ``alarm`` events are the drones' alarms, already
        validated and checked against the topic they came on."""
        if event == "alarm":
            self.add(AlarmSource.DRONE, data)

    def on_separation_alarm(self, alarm: dict[str, Any]) -> None:
        self.add(AlarmSource.SEPARATION, alarm)

    def add(self, source: str, alarm: dict[str, Any]) -> None:
        try:
            self._queue.put_nowait((timestamp_s(), source, alarm))
        except asyncio.QueueFull:
            self.dropped += 1
            if self.dropped % 1000 == 1:
                log.warning("alarm log: %d alarms dropped (queue full)", self.dropped)

    async def flush(self) -> None:
        """Return once every alarm queued so far is written."""
        await self._queue.join()

    async def _write_forever(self) -> None:
        while True:
            batch = [await self._queue.get()]
            while len(batch) < BATCH and not self._queue.empty():
                batch.append(self._queue.get_nowait())
            try:
                await self._write(batch)
            except Exception:
                log.exception("alarm log: %d alarms not written", len(batch))
            finally:
                for _ in batch:
                    self._queue.task_done()

    async def _write(self, batch: list[tuple[float, str, dict[str, Any]]]) -> None:
        rows = [
            (
                received_at,
                str(alarm.get("drone_id", "")),
                str(alarm.get("level", "")),
                source,
                alarm.get("mission_id"),
                orjson.dumps(alarm, default=str).decode(),
                fingerprint(source, alarm),
            )
            for received_at, source, alarm in batch
        ]
        await self.state.write_many(
            # ON CONFLICT, not SQLite's OR IGNORE: the same statement on PostgreSQL.
            "INSERT INTO alarms (received_at, drone_id, level, source, mission_id,"
            " alarm, fingerprint) VALUES (?, ?, ?, ?, ?, ?, ?) ON CONFLICT DO NOTHING",
            rows,
        )
        await self._trim()

    async def _trim(self) -> None:
        (newest,) = (await self.state.rows("SELECT COALESCE(MAX(id), 0) FROM alarms"))[0]
        floor = newest - self.max_rows
        if floor <= 0:
            return
        # Acknowledged ones go a tenth earlier: an alarm nobody has seen yet is kept longest.
        acked_floor = floor + self.max_rows // 10
        await self.state.write(
            ("DELETE FROM alarms WHERE id <= ? AND acked_at IS NOT NULL", (acked_floor,)),
            ("DELETE FROM alarms WHERE id <= ?", (floor,)),
        )

    # -- out ---------------------------------------------------------------------------------
    async def query(
        self, where: AlarmFilter, *, limit: int = 100, unacknowledged_first: bool = False
    ) -> list[dict[str, Any]]:
        sql, args = where.where()
        order = "(acked_at IS NOT NULL), id DESC" if unacknowledged_first else "id DESC"
        rows = await self.state.rows(
            f"SELECT {_COLUMNS} FROM alarms{sql} ORDER BY {order} LIMIT ?", [*args, limit]
        )
        return [_entry(r) for r in rows]

    async def count(self, where: AlarmFilter) -> int:
        sql, args = where.where()
        return int((await self.state.rows(f"SELECT COUNT(*) FROM alarms{sql}", args))[0][0])

    async def latest_per_drone(self) -> list[dict[str, Any]]:
        """Each drone's newest alarm (the fleet table's "Last alarm" after a reload)."""
        rows = await self.state.rows(
            f"SELECT {_COLUMNS} FROM alarms WHERE id IN"
            " (SELECT MAX(id) FROM alarms GROUP BY drone_id) ORDER BY drone_id"
        )
        return [_entry(r) for r in rows]

    async def get(self, alarm_id: int) -> dict[str, Any]:
        rows = await self.state.rows(f"SELECT {_COLUMNS} FROM alarms WHERE id = ?", (alarm_id,))
        if not rows:
            raise NotFound(f"no alarm {alarm_id} in the log")
        return _entry(rows[0])

    async def acknowledge(self, alarm_id: int, who: str) -> dict[str, Any]:
        """Mark the alarm acknowledged by ``who`` now; NotFound or Conflict (already, by whom)."""
        (changed,) = await self.state.write(
            (
                "UPDATE alarms SET acked_at = ?, acked_by = ? WHERE id = ? AND acked_at IS NULL",
                (timestamp_s(), who, alarm_id),
            )
        )
        entry = await self.get(alarm_id)
        if not changed:
            raise Conflict(
                f"alarm {alarm_id} was already acknowledged by {entry['acked_by']}",
                acked_by=entry["acked_by"],
                acked_at=entry["acked_at"],
            )
        return entry
