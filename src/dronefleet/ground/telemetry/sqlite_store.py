"""SQLite telemetry store: the embedded default Time Series Database (seed 4.2.2.1 used InfluxDB).

A row per message, its fields as one JSON object (``telemetry_points``), so any field a drone
sends can be stored; read as the narrow view ``telemetry (drone, time_us, field, value)``, with
the same epoch-aligned mean-per-bucket downsampling as InfluxDB's ``GROUP BY time()``. WAL mode,
through aiosqlite (one connection on its own thread, so the event loop never waits on disk; a
kept library instead of our own executor wrapper), every call held on virtual time as in
ground/state.py.

A batch is one transaction and one statement: its points go in as one JSON parameter (encoded
by orjson) and SQLite unpacks them (``json_each``). ``executemany`` took the GIL back for every
row between SQLite steps, so while the event loop was busy each row waited for it (up to the
interpreter's 5 ms switch interval): on an idle two-core host 32,000 rows took 10 s instead of
0.08 s, and at a thousand drones 4.5 % of the telemetry was stored (issue 27,
bench/ground_capacity.py). It was then a row per field: 16 rows per message, each with its index
entry, 0.041-0.057 ms of CPU per message against 0.010-0.014 ms for a row per message (5,000
messages of 16 fields, measured with SQLite alone), with half the write-ahead log. A store
written then keeps its rows (``telemetry_rows``), still read.

A row is a **run**: one drone's points of one batch, in time order (``telemetry_runs``, at most
:data:`RUN_SPAN_US` apart), so the index by drone and time gets an entry a run, not a point.
That index is most of a row's cost: each new entry goes in its drone's place, among thousands of
drones' (2,500 drones' points into a table of a million, SQLite alone: 17 us a point at a row a
point, 8-11 us in runs of 2-4 points; at 12,500 points a second a replica's writer thread took
0.25 of its one core, issue 27, bench/replica_share.py). A store written a row a point keeps
those rows (``telemetry_points``), still read.
"""

from __future__ import annotations

import asyncio
import contextlib
from operator import itemgetter
from pathlib import Path
from typing import Any

import aiosqlite
import orjson

from dronefleet.ground.sqlite_file import open_sqlite
from dronefleet.ground.telemetry.store import (
    TelemetryPoint,
    TelemetryQuery,
    TelemetrySeries,
    round_value,
)
from dronefleet.owner_only import private_file
from dronefleet.virtual_loop import held

_SCHEMA = """
CREATE TABLE IF NOT EXISTS telemetry_rows (
    drone TEXT NOT NULL,
    time_us INTEGER NOT NULL,
    field TEXT NOT NULL,
    value REAL NOT NULL
);
CREATE INDEX IF NOT EXISTS telemetry_drone_time ON telemetry_rows (drone, time_us);
CREATE TABLE IF NOT EXISTS telemetry_points (
    drone TEXT NOT NULL,
    time_us INTEGER NOT NULL,
    fields TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS telemetry_points_drone_time ON telemetry_points (drone, time_us);
CREATE TABLE IF NOT EXISTS telemetry_runs (
    drone TEXT NOT NULL,
    first_us INTEGER NOT NULL,
    last_us INTEGER NOT NULL,
    n INTEGER NOT NULL,
    points TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS telemetry_runs_drone_time ON telemetry_runs (drone, first_us);
DROP VIEW IF EXISTS telemetry;
CREATE VIEW telemetry (drone, time_us, field, value) AS
    SELECT drone, time_us, field, value FROM telemetry_rows
    UNION ALL
    SELECT p.drone, p.time_us, f.key, f.value FROM telemetry_points AS p, json_each(p.fields) AS f
    UNION ALL
    SELECT r.drone, json_extract(p.value, '$[0]'), f.key, f.value
    FROM telemetry_runs AS r, json_each(r.points) AS p, json_each(p.value, '$[1]') AS f;
"""
#: Longest a run spans, first point to last (microseconds): a query reads, through the index,
#: the runs that begin up to this long before its range. A batch spans a flush period unless
#: the store was away; then a drone's points are cut into runs of this span.
RUN_SPAN_US = 10_000_000
#: A batch of runs, ``[[drone, first_us, last_us, n, [[time_us, {field: value}], ...]], ...]``.
_INSERT = """
INSERT INTO telemetry_runs (drone, first_us, last_us, n, points)
SELECT json_extract(value, '$[0]'), json_extract(value, '$[1]'), json_extract(value, '$[2]'),
    json_extract(value, '$[3]'), json_extract(value, '$[4]')
FROM json_each(?)
"""
#: One drone's fields, mean per bucket, from the three tables (each through its own index).
_QUERY = """
SELECT field, bucket, AVG(value) FROM (
    SELECT field, (time_us / :every) * :every AS bucket, value FROM telemetry_rows
    WHERE drone = :drone AND time_us >= :from_us AND time_us < :to_us {rows_fields}
    UNION ALL
    SELECT f.key AS field, (p.time_us / :every) * :every AS bucket, f.value AS value
    FROM telemetry_points AS p, json_each(p.fields) AS f
    WHERE p.drone = :drone AND p.time_us >= :from_us AND p.time_us < :to_us {points_fields}
    UNION ALL
    SELECT f.key AS field, (t.time_us / :every) * :every AS bucket, f.value AS value
    FROM (
        SELECT json_extract(p.value, '$[0]') AS time_us, p.value AS point
        FROM telemetry_runs AS r, json_each(r.points) AS p
        WHERE r.drone = :drone AND r.first_us >= :from_us - :span AND r.first_us < :to_us
    ) AS t, json_each(t.point, '$[1]') AS f
    WHERE t.time_us >= :from_us AND t.time_us < :to_us {points_fields}
) GROUP BY field, bucket ORDER BY field, bucket
"""


async def _rows_table_renamed(db: aiosqlite.Connection) -> None:
    """A store written by an earlier ground, a row per field in the table ``telemetry``: that
    table becomes ``telemetry_rows``, still read; ``telemetry`` is then the view of both."""
    cursor = await held(db.execute("SELECT type FROM sqlite_master WHERE name = 'telemetry'"))
    try:
        row = await held(cursor.fetchone())
    finally:
        await held(cursor.close())
    if row is not None and row[0] == "table":
        await held(db.execute("ALTER TABLE telemetry RENAME TO telemetry_rows"))


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
        self._db = await open_sqlite(
            self.path, _SCHEMA, f"--store {self.url}", upgrade=_rows_table_renamed
        )

    async def close(self) -> None:
        if self._db is not None:
            db, self._db = self._db, None
            await held(db.close())

    async def write(self, points: list[TelemetryPoint]) -> int:
        batch = orjson.dumps(runs(points))
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
        args: dict[str, object] = {
            "span": RUN_SPAN_US,
            "every": query.every_us,
            "drone": query.drone_id,
            "from_us": query.from_us,
            "to_us": query.to_us,
        }
        rows_fields = points_fields = ""
        if query.fields:
            names = ", ".join(f":f{i}" for i in range(len(query.fields)))
            rows_fields, points_fields = f"AND field IN ({names})", f"AND f.key IN ({names})"
            args.update({f"f{i}": name for i, name in enumerate(query.fields)})
        sql = _QUERY.format(rows_fields=rows_fields, points_fields=points_fields)
        cursor = await held(self.db.execute(sql, args))
        try:
            rows = await held(cursor.fetchall())
        finally:
            await held(cursor.close())
        result = TelemetrySeries(query)
        for name, bucket, mean in rows:
            result.series.setdefault(name, []).append((bucket / 1e6, round_value(mean)))
        return result


def runs(points: list[TelemetryPoint]) -> list[tuple[str, int, int, int, list[Any]]]:
    """``points`` as rows of ``telemetry_runs``: each drone's, in time order, cut where a run
    would span more than :data:`RUN_SPAN_US`."""
    by_drone: dict[str, list[tuple[int, dict[str, float]]]] = {}
    for p in points:
        try:
            by_drone[p.drone_id].append((p.time_us, p.fields))
        except KeyError:
            by_drone[p.drone_id] = [(p.time_us, p.fields)]
    rows: list[tuple[str, int, int, int, list[Any]]] = []
    for drone_id, run in by_drone.items():
        run.sort(key=itemgetter(0))  # by time
        while run[-1][0] - run[0][0] > RUN_SPAN_US:
            cut = next(i for i, (t, _) in enumerate(run) if t - run[0][0] > RUN_SPAN_US)
            rows.append((drone_id, run[0][0], run[cut - 1][0], cut, run[:cut]))
            run = run[cut:]
        rows.append((drone_id, run[0][0], run[-1][0], len(run), run))
    return rows
