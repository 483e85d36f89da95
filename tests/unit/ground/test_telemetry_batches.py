"""The SQLite telemetry store writes a batch as one transaction and one statement
(ground/telemetry/sqlite_store.py): a row per point, read back as written; a store written by an
earlier ground (a row per field) is still read."""

from __future__ import annotations

import sqlite3
import threading
import time

from dronefleet.ground.telemetry.sqlite_store import SqliteTelemetryStore
from dronefleet.ground.telemetry.store import TelemetryPoint, TelemetryQuery

T0 = 1_700_000_000_000_000


async def test_a_batch_of_points_is_stored_in_one_statement_a_row_per_point(tmp_path) -> None:
    store = SqliteTelemetryStore(str(tmp_path / "t.db"))
    await store.open()
    try:
        fields = {"lat": 40.6, "lon": -8.6, "alt_m": 30.0, "battery_pct": 76.5}
        points = [TelemetryPoint(f"QUAD_{n % 3}", T0 + n * 200_000, fields) for n in range(3_000)]
        assert await store.write(points) == 3_000
        async with store.db.execute("SELECT COUNT(*) FROM telemetry_points") as cursor:
            assert await cursor.fetchone() == (3_000,)
        # Read as the narrow view: a row per field, each value a number.
        async with store.db.execute("SELECT COUNT(*), typeof(value) FROM telemetry") as cursor:
            assert await cursor.fetchone() == (12_000, "real")
        query = TelemetryQuery("QUAD_1", T0, T0 + 3_000 * 200_000, 1_000_000, ("lat",))
        series = (await store.query(query)).series
        assert len(series["lat"]) == 600 and series["lat"][0] == (T0 / 1e6, 40.6)
    finally:
        await store.close()


async def test_a_busy_event_loop_does_not_slow_a_batch_down(tmp_path) -> None:
    # executemany took the GIL back between rows: beside a busy thread, on an idle two-core
    # host, 32,000 rows took 10 s instead of 0.08 s (less on a loaded one, where the busy
    # thread is preempted anyway). One statement takes it back once per batch.
    store = SqliteTelemetryStore(str(tmp_path / "t.db"))
    await store.open()
    fields = {f"f{n}": float(n) for n in range(16)}
    points = [TelemetryPoint(f"QUAD_{n % 100}", T0 + n, fields) for n in range(2_000)]
    busy = threading.Event()

    def spin() -> None:
        while not busy.is_set():
            pass

    spinner = threading.Thread(target=spin)
    spinner.start()
    try:
        began = time.perf_counter()
        await store.write(points)
        took = time.perf_counter() - began
    finally:
        busy.set()
        spinner.join()
        await store.close()
    assert took < 3.0, f"32,000 rows took {took:.1f} s beside a busy thread"


async def test_a_store_of_an_earlier_ground_is_read_with_what_comes_after(tmp_path) -> None:
    path = tmp_path / "old.db"
    with sqlite3.connect(path) as db:  # the schema before, a row per field
        db.executescript(
            "CREATE TABLE telemetry (drone TEXT NOT NULL, time_us INTEGER NOT NULL,"
            " field TEXT NOT NULL, value REAL NOT NULL);"
            "CREATE INDEX telemetry_drone_time ON telemetry (drone, time_us);"
        )
        db.executemany(
            "INSERT INTO telemetry VALUES ('QUAD_1', ?, ?, ?)",
            [
                (T0 + n * 500_000, f, v)
                for n in range(4)
                for f, v in (("lat", 40.0), ("alt_m", 10.0))
            ],
        )
    store = SqliteTelemetryStore(str(path))
    await store.open()
    try:
        later = [
            TelemetryPoint("QUAD_1", T0 + 2_000_000 + n * 500_000, {"lat": 41.0}) for n in range(4)
        ]
        await store.write(later)
        query = TelemetryQuery("QUAD_1", T0, T0 + 4_000_000, 1_000_000, ("lat",))
        series = (await store.query(query)).series
        assert series == {
            "lat": [(T0 / 1e6 + k, v) for k, v in enumerate([40.0, 40.0, 41.0, 41.0])]
        }
        everything = (
            await store.query(TelemetryQuery("QUAD_1", T0, T0 + 4_000_000, 4_000_000))
        ).series
        assert everything == {"alt_m": [(T0 / 1e6, 10.0)], "lat": [(T0 / 1e6, 40.5)]}
    finally:
        await store.close()
    store = SqliteTelemetryStore(str(path))  # opened again: nothing renamed twice, nothing lost
    await store.open()
    try:
        async with store.db.execute("SELECT COUNT(*) FROM telemetry") as cursor:
            assert await cursor.fetchone() == (12,)
    finally:
        await store.close()
