"""SQLite telemetry store: the embedded default Time Series Database (seed 4.2.2.1 used InfluxDB).

One narrow table ``(drone, time_us, field, value)`` so any field a drone sends can be stored; the
same epoch-aligned mean-per-bucket downsampling as InfluxDB's ``GROUP BY time()``. WAL mode, and
one worker thread so the event loop never waits on disk.
"""

from __future__ import annotations

import asyncio
import sqlite3
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import TypeVar

from dronefleet.ground.telemetry.store import (
    TelemetryPoint,
    TelemetryQuery,
    TelemetrySeries,
    round_value,
)

T = TypeVar("T")

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
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="telemetry-sqlite")
        self._db: sqlite3.Connection | None = None

    async def _call(self, fn: Callable[[sqlite3.Connection], T]) -> T:
        def call() -> T:
            assert self._db is not None, "telemetry store is not open"
            return fn(self._db)

        return await asyncio.get_running_loop().run_in_executor(self._executor, call)

    async def open(self) -> None:
        def connect() -> None:
            if self.path != ":memory:":
                Path(self.path).parent.mkdir(parents=True, exist_ok=True)
            db = sqlite3.connect(self.path, isolation_level=None)
            db.execute("PRAGMA journal_mode=WAL")
            db.execute("PRAGMA synchronous=NORMAL")
            db.executescript(_SCHEMA)
            self._db = db

        await asyncio.get_running_loop().run_in_executor(self._executor, connect)

    async def close(self) -> None:
        if self._db is not None:
            await self._call(lambda db: db.close())
            self._db = None
        self._executor.shutdown(wait=True)

    async def write(self, points: list[TelemetryPoint]) -> int:
        rows = [(p.drone_id, p.time_us, k, v) for p in points for k, v in p.fields.items()]

        def insert(db: sqlite3.Connection) -> None:
            with db:
                db.executemany("INSERT INTO telemetry VALUES (?, ?, ?, ?)", rows)

        await self._call(insert)
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
        rows = await self._call(lambda db: db.execute(sql, args).fetchall())
        result = TelemetrySeries(query)
        for name, bucket, mean in rows:
            result.series.setdefault(name, []).append((bucket / 1e6, round_value(mean)))
        return result
