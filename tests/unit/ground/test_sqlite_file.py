"""The ground's SQLite files on files it did not make (ground/sqlite_file.py): another program's
database is refused, naming the option and the table, and left byte for byte as it was; an
older ground's file, with columns added since, is taken."""

from __future__ import annotations

import sqlite3
import threading

import pytest

from dronefleet.clock import WallClock, wait_until
from dronefleet.errors import InvalidInput
from dronefleet.ground.broker_credentials import BrokerCredentials
from dronefleet.ground.sqlite_file import tables_made_by
from dronefleet.ground.state import StateStore
from dronefleet.ground.telemetry.sqlite_store import SqliteTelemetryStore


def made(path, *statements: str) -> bytes:
    with sqlite3.connect(path) as db:
        for statement in statements:
            db.execute(statement)
    db.close()
    return path.read_bytes()


def connection_threads() -> list[threading.Thread]:
    """aiosqlite's worker threads (a thread's name carries its target's)."""
    return [t for t in threading.enumerate() if "_connection_worker_thread" in t.name]


def test_a_scripts_tables_are_read_by_sqlite_itself() -> None:
    script = """
    CREATE TABLE IF NOT EXISTS a (x TEXT PRIMARY KEY, y REAL NOT NULL);
    CREATE INDEX IF NOT EXISTS a_y ON a (y);
    CREATE TABLE IF NOT EXISTS "b c" (z INTEGER);
    CREATE VIEW IF NOT EXISTS v AS SELECT x FROM a;
    """
    assert tables_made_by(script) == {"a": {"x", "y"}, "b c": {"z"}}


@pytest.mark.parametrize(
    ("open_store", "table", "option"),
    [
        (lambda path: StateStore(path).open(), "drones", "--state"),
        (lambda path: SqliteTelemetryStore(str(path)).open(), "telemetry_runs", "--store"),
    ],
    ids=["state", "telemetry"],
)
async def test_another_programs_table_is_refused_and_its_file_left_as_it_was(
    tmp_path, open_store, table, option
) -> None:
    path = tmp_path / "theirs.db"
    before = made(path, f"CREATE TABLE {table} (id INTEGER, name TEXT)", "CREATE TABLE t (a)")
    threads = set(connection_threads())
    with pytest.raises(InvalidInput, match=f"^{option} .*its table {table} is not the ground's"):
        await open_store(path)
    assert path.read_bytes() == before
    assert not (tmp_path / "theirs.db-wal").exists()  # not even turned to WAL
    # The connection was closed: its thread (not a daemon) would keep the process alive.
    assert await wait_until(
        WallClock(), lambda: set(connection_threads()) <= threads, timeout_s=5.0
    )


async def test_a_rooms_table_of_another_program_is_refused_before_its_script_runs(tmp_path):
    path = tmp_path / "ground.db"
    made(path, "CREATE TABLE broker_users (login TEXT, secret BLOB)")
    state = await StateStore(path).open()
    try:
        with pytest.raises(InvalidInput, match=r"its table broker_users .*name, password_hash"):
            await BrokerCredentials(state).open()
        assert await state.columns("broker_users") == {"login", "secret"}
    finally:
        await state.close()


async def test_an_older_grounds_file_with_columns_added_since_is_taken(tmp_path):
    path = tmp_path / "ground.db"
    made(
        path,
        "CREATE TABLE drones (drone_id TEXT PRIMARY KEY, record TEXT NOT NULL, "
        "updated_at REAL NOT NULL, note TEXT)",
        "CREATE TABLE broker_users (name TEXT PRIMARY KEY, role TEXT NOT NULL, "
        "password_hash TEXT NOT NULL, created_at REAL NOT NULL)",  # before rabbit_hash
    )
    state = await StateStore(path).open()
    try:
        await BrokerCredentials(state).open()
        assert "rabbit_hash" in await state.columns("broker_users")
        assert "note" in await state.columns("drones")
    finally:
        await state.close()
