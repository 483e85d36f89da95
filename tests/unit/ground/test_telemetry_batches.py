"""The SQLite telemetry store writes a batch as one transaction and one statement
(ground/telemetry/sqlite_store.py): a row per drone's run of points, read back as written; a store
written by an earlier ground (a row per field, a row per point) is still read."""

from __future__ import annotations

import sqlite3
import threading
import time

from dronefleet.ground.telemetry.sqlite_store import RUN_SPAN_US, SqliteTelemetryStore, runs
from dronefleet.ground.telemetry.store import TelemetryPoint, TelemetryQuery

T0 = 1_700_000_000_000_000


async def test_a_batch_of_points_is_stored_in_one_statement_a_row_per_run(tmp_path) -> None:
    store = SqliteTelemetryStore(str(tmp_path / "t.db"))
    await store.open()
    try:
        fields = {"lat": 40.6, "lon": -8.6, "alt_m": 30.0, "battery_pct": 76.5}
        points = [TelemetryPoint(f"QUAD_{n % 3}", T0 + n * 200_000, fields) for n in range(3_000)]
        assert await store.write(points) == 3_000
        # Each drone's 1,000 points span 600 s: runs of at most RUN_SPAN_US (10 s), 17 points.
        async with store.db.execute("SELECT COUNT(*), SUM(n) FROM telemetry_runs") as cursor:
            assert await cursor.fetchone() == (3 * 59, 3_000)
        async with store.db.execute(
            "SELECT MAX(last_us - first_us), MIN(n), MAX(n) FROM telemetry_runs"
        ) as cursor:
            assert await cursor.fetchone() == (RUN_SPAN_US - 400_000, 14, 17)
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


def test_a_drones_points_make_runs_in_time_order_whatever_order_they_came_in() -> None:
    late, early = {"lat": 2.0}, {"lat": 1.0}
    points = [
        TelemetryPoint("B", T0 + 400_000, late),
        TelemetryPoint("A", T0 + 200_000, late),
        TelemetryPoint("A", T0, early),
        TelemetryPoint("B", T0 + RUN_SPAN_US + 400_001, late),  # beyond B's first run
    ]
    assert runs(points) == [
        ("B", T0 + 400_000, T0 + 400_000, 1, [(T0 + 400_000, late)]),
        ("B", T0 + RUN_SPAN_US + 400_001, T0 + RUN_SPAN_US + 400_001, 1,
         [(T0 + RUN_SPAN_US + 400_001, late)]),
        ("A", T0, T0 + 200_000, 2, [(T0, early), (T0 + 200_000, late)]),
    ]  # fmt: skip


async def test_a_query_takes_the_points_of_its_range_from_runs_across_its_edges(tmp_path) -> None:
    # Runs of a second each (written a second at a time); a range that begins and ends inside
    # runs, and one that begins a whole span after a run began, take exactly their points.
    store = SqliteTelemetryStore(str(tmp_path / "t.db"))
    await store.open()
    try:
        for second in range(30):
            await store.write(
                [TelemetryPoint("QUAD_1", T0 + second * 1_000_000 + k * 100_000,
                                {"n": float(second * 10 + k)}) for k in range(10)]
            )  # fmt: skip
        for from_n, to_n in ((5, 17), (0, 300), (123, 124), (150, 299), (299, 300)):
            query = TelemetryQuery(
                "QUAD_1", T0 + from_n * 100_000, T0 + to_n * 100_000, 100_000, ("n",)
            )
            series = (await store.query(query)).series
            assert [v for _, v in series["n"]] == [float(n) for n in range(from_n, to_n)]
        async with store.db.execute(
            "EXPLAIN QUERY PLAN SELECT * FROM telemetry_runs WHERE drone = 'QUAD_1' "
            "AND first_us >= 0 AND first_us < 1"
        ) as cursor:
            plan = " ".join(str(row[-1]) for row in await cursor.fetchall())
        assert "telemetry_runs_drone_time (drone=? AND first_us>? AND first_us<?)" in plan
    finally:
        await store.close()


async def test_a_store_written_a_row_a_point_is_read_with_what_comes_after(tmp_path) -> None:
    path = tmp_path / "points.db"
    with sqlite3.connect(path) as db:  # the schema before runs: a row per point
        db.executescript(
            "CREATE TABLE telemetry_points (drone TEXT NOT NULL, time_us INTEGER NOT NULL,"
            " fields TEXT NOT NULL);"
            "CREATE INDEX telemetry_points_drone_time ON telemetry_points (drone, time_us);"
        )
        db.executemany(
            "INSERT INTO telemetry_points VALUES ('QUAD_1', ?, ?)",
            [(T0 + n * 500_000, '{"lat": 40.0}') for n in range(4)],
        )
    store = SqliteTelemetryStore(str(path))
    await store.open()
    try:
        await store.write(
            [
                TelemetryPoint("QUAD_1", T0 + 2_000_000 + n * 500_000, {"lat": 41.0})
                for n in range(4)
            ]
        )
        query = TelemetryQuery("QUAD_1", T0, T0 + 4_000_000, 1_000_000, ("lat",))
        series = (await store.query(query)).series
        assert series == {
            "lat": [(T0 / 1e6 + k, v) for k, v in enumerate([40.0, 40.0, 41.0, 41.0])]
        }
        async with store.db.execute("SELECT COUNT(*) FROM telemetry") as cursor:
            assert await cursor.fetchone() == (8,)
    finally:
        await store.close()
