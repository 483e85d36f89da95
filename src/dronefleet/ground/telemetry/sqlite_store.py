"""SQLite telemetry store: the embedded default Time Series Database (seed 4.2.2.1 used InfluxDB).

One narrow table ``(drone, time_us, field, value)`` so any field a drone sends can be stored; the
same epoch-aligned mean-per-bucket downsampling as InfluxDB's ``GROUP BY time()``. WAL mode, through
aiosqlite (one connection on its own thread, so the event loop never waits on disk; a kept library
instead of our own executor wrapper), every call held on virtual time as in ground/state.py.
"""

from __future__ import annotations

import asyncio
import contextlib
from pathlib import Path

import aiosqlite

from dronefleet.ground.telemetry.store import (
    TelemetryPoint,
    TelemetryQuery,
    TelemetrySeries,
    round_value,
)
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
            await asyncio.to_thread(Path(self.path).parent.mkdir, parents=True, exist_ok=True)
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
        rows = [(p.drone_id, p.time_us, k, v) for p in points for k, v in p.fields.items()]
        async with self._writing:  # one batch, one transaction
            try:
                await held(self.db.execute("BEGIN"))
                await held(self.db.executemany("INSERT INTO telemetry VALUES (?, ?, ?, ?)", rows))
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
