"""SQLite telemetry store: the embedded default Time Series Database (seed 4.2.2.1 used InfluxDB).

One narrow table ``(drone, time_us, field, value)`` so any field a drone sends can be stored; the
same epoch-aligned mean-per-bucket downsampling as InfluxDB's ``GROUP BY time()``. WAL mode, through
aiosqlite (one connection on its own thread, so the event loop never waits on disk; a kept library
instead of our own executor wrapper), every call held on virtual time as in ground/state.py.

A batch is one transaction and one statement: its points go in as one JSON parameter (encoded by
orjson) and SQLite unpacks them (``json_each``), a row per field. ``executemany`` took the GIL
back for every row between SQLite steps, so while the event loop was busy each row waited for
it (up to the interpreter's 5 ms switch interval): on an idle two-core host 32,000 rows took 10 s
instead of 0.08 s, and at a thousand drones 4.5 % of the telemetry was stored (issue 27,
bench/ground_capacity.py).
"""

from __future__ import annotations

import asyncio
import contextlib
import sqlite3
from pathlib import Path

import aiosqlite
import orjson

from dronefleet.ground.telemetry.store import (
    TelemetryPoint,
    TelemetryQuery,
    TelemetrySeries,
    round_value,
)
from dronefleet.owner_only import private_file
from dronefleet.virtual_loop import held

_SCHEMA = """
CREATE TABLE IF NOT EXISTS telemetry (
    drone TEXT NOT NULL,
    time_us INTEGER NOT NULL,
    field TEXT NOT NULL,
    value REAL NOT NULL
);
CREATE INDEX IF NOT EXISTS telemetry_drone_time ON telemetry (drone, time_us);
"""
#: A batch of points, ``[[drone, time_us, {field: value}], ...]``, as rows: each point's parts
#: read once (MATERIALIZED: SQLite 3.35+), then a row per field.
_MATERIALIZED = "MATERIALIZED" if sqlite3.sqlite_version_info >= (3, 35) else ""
_INSERT = f"""
WITH points AS {_MATERIALIZED} (
    SELECT json_extract(value, '$[0]') AS drone, json_extract(value, '$[1]') AS time_us,
           json_extract(value, '$[2]') AS fields
    FROM json_each(?)
)
INSERT INTO telemetry (drone, time_us, field, value)
SELECT points.drone, points.time_us, f.key, f.value FROM points, json_each(points.fields) AS f
"""


class SqliteTelemetryStore:
    def __init__(self, path: str, *, url: str | None = None) -> None:
        self.path = path
        self.url = url or f"sqlite:///{path}"
        self._db: aiosqlite.Connection | None = None
        self._writing = asyncio.Lock()  # one transaction at a time on the one connection

    @property
    def db(self) -> aiosqlite.Connection:
        if self._db is None:
            raise RuntimeError("telemetry store is not open")
        return self._db

    async def open(self) -> None:
        if self.path != ":memory:":
            # The owner's only (issue 25): made 0600 before SQLite opens it, so its -wal and
            # -shm files are too; one left 0644 by an earlier version is closed to others.
            await asyncio.to_thread(private_file, Path(self.path))
        db = await held(aiosqlite.connect(self.path, isolation_level=None))
        await held(db.execute("PRAGMA journal_mode=WAL"))
        await held(db.execute("PRAGMA synchronous=NORMAL"))
        await held(db.executescript(_SCHEMA))
        self._db = db

    async def close(self) -> None:
        if self._db is not None:
            db, self._db = self._db, None
            await held(db.close())

    async def write(self, points: list[TelemetryPoint]) -> int:
        batch = orjson.dumps([(p.drone_id, p.time_us, p.fields) for p in points])
        async with self._writing:  # one batch, one transaction, one statement
            try:
                await held(self.db.execute("BEGIN"))
                await held(self.db.execute(_INSERT, (batch,)))
                await held(self.db.execute("COMMIT"))
            except BaseException:
                with contextlib.suppress(Exception):  # see ground/state.py _roll_back
                    await held(asyncio.shield(self.db.rollback()))
                raise
        return len(points)

    async def query(self, query: TelemetryQuery) -> TelemetrySeries:
        sql = (
            "SELECT field, (time_us / :every) * :every AS bucket, AVG(value) FROM telemetry "
            "WHERE drone = :drone AND time_us >= :from_us AND time_us < :to_us"
        )
        args: dict[str, object] = {
            "every": query.every_us,
            "drone": query.drone_id,
            "from_us": query.from_us,
            "to_us": query.to_us,
        }
        if query.fields:
            names = [f":f{i}" for i in range(len(query.fields))]
            sql += f" AND field IN ({', '.join(names)})"
            args.update({f"f{i}": name for i, name in enumerate(query.fields)})
        sql += " GROUP BY field, bucket ORDER BY field, bucket"
        cursor = await held(self.db.execute(sql, args))
        try:
            rows = await held(cursor.fetchall())
        finally:
            await held(cursor.close())
        result = TelemetrySeries(query)
        for name, bucket, mean in rows:
            result.series.setdefault(name, []).append((bucket / 1e6, round_value(mean)))
        return result
