"""The ground state store (docs/DESIGN.md §7): drones seen, API tokens, the audit log of every
command.

SQLite in WAL mode, used from one worker thread so the event loop never blocks on disk. The
Drone Identifier keeps its fleet here so a restart remembers it; the Drone Manager keeps tokens
(hashed) and the audit log (the seed's logging requirement 3.1.6). Later rooms (the Mission
Planner) add their own tables through :meth:`StateStore.run`.
"""

from __future__ import annotations

import asyncio
import os
import sqlite3
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, TypeVar

import orjson

from dronefleet.clock import timestamp_s

T = TypeVar("T")

_SCHEMA = """
CREATE TABLE IF NOT EXISTS drones (
    drone_id TEXT PRIMARY KEY,
    record TEXT NOT NULL,
    updated_at REAL NOT NULL
);
CREATE TABLE IF NOT EXISTS tokens (
    token_hash TEXT PRIMARY KEY,
    name TEXT NOT NULL UNIQUE,
    role TEXT NOT NULL,
    created_at REAL NOT NULL
);
CREATE TABLE IF NOT EXISTS audit (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    ts REAL NOT NULL,
    who TEXT NOT NULL,
    role TEXT NOT NULL,
    drone_id TEXT,
    command TEXT NOT NULL,
    params TEXT NOT NULL,
    status INTEGER NOT NULL,
    answer TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS audit_drone ON audit (drone_id, id);
"""


class StateStore:
    """One SQLite file (``:memory:`` for tests), reached through :meth:`run` on its own thread."""

    def __init__(self, path: str | Path) -> None:
        self.path = str(path)
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="ground-state")
        self._db: sqlite3.Connection | None = None

    async def open(self) -> StateStore:
        await self._call(self._open)
        return self

    def _open(self) -> None:
        if self.path != ":memory:":
            Path(self.path).parent.mkdir(parents=True, exist_ok=True)
            # Token hashes and the audit log: the owner's only (SQLite gives its -wal and -shm
            # files the database's mode).
            Path(self.path).touch(mode=0o600, exist_ok=True)
            os.chmod(self.path, 0o600)
        db = sqlite3.connect(self.path, isolation_level=None)
        db.execute("PRAGMA journal_mode=WAL")
        db.execute("PRAGMA synchronous=NORMAL")
        db.executescript(_SCHEMA)
        self._db = db

    async def close(self) -> None:
        if self._db is not None:
            await self._call(self._db.close)
            self._db = None
        self._executor.shutdown(wait=True)

    async def _call(self, fn: Callable[..., T], *args: Any) -> T:
        return await asyncio.get_running_loop().run_in_executor(self._executor, fn, *args)

    async def run(self, fn: Callable[[sqlite3.Connection], T]) -> T:
        """Run ``fn(connection)`` on the store's thread (for tables other rooms add)."""

        def call() -> T:
            assert self._db is not None, "state store is not open"
            return fn(self._db)

        return await self._call(call)

    # -- drones --------------------------------------------------------------------------------
    async def save_drones(self, records: list[dict[str, Any]]) -> None:
        now = timestamp_s()
        rows = [(r["drone_id"], orjson.dumps(r).decode(), now) for r in records]

        def write(db: sqlite3.Connection) -> None:
            with db:
                db.executemany(
                    "INSERT INTO drones (drone_id, record, updated_at) VALUES (?, ?, ?) "
                    "ON CONFLICT (drone_id) DO UPDATE SET record = excluded.record, "
                    "updated_at = excluded.updated_at",
                    rows,
                )

        await self.run(write)

    async def load_drones(self) -> list[dict[str, Any]]:
        rows = await self.run(
            lambda db: db.execute("SELECT record FROM drones ORDER BY drone_id").fetchall()
        )
        return [orjson.loads(r[0]) for r in rows]

    # -- tokens --------------------------------------------------------------------------------
    async def add_token(self, token_hash: str, name: str, role: str) -> None:
        def write(db: sqlite3.Connection) -> None:
            with db:
                db.execute(
                    "DELETE FROM tokens WHERE name = ? OR token_hash = ?", (name, token_hash)
                )
                db.execute(
                    "INSERT INTO tokens (token_hash, name, role, created_at) VALUES (?, ?, ?, ?)",
                    (token_hash, name, role, timestamp_s()),
                )

        await self.run(write)

    async def find_token(self, token_hash: str) -> tuple[str, str] | None:
        row = await self.run(
            lambda db: db.execute(
                "SELECT name, role FROM tokens WHERE token_hash = ?", (token_hash,)
            ).fetchone()
        )
        return (row[0], row[1]) if row else None

    async def list_tokens(self) -> list[dict[str, Any]]:
        rows = await self.run(
            lambda db: db.execute(
                "SELECT name, role, created_at FROM tokens ORDER BY created_at"
            ).fetchall()
        )
        return [{"name": n, "role": r, "created_at": c} for n, r, c in rows]

    async def delete_token(self, name: str) -> bool:
        def write(db: sqlite3.Connection) -> bool:
            with db:
                return db.execute("DELETE FROM tokens WHERE name = ?", (name,)).rowcount > 0

        return await self.run(write)

    # -- audit log -----------------------------------------------------------------------------
    async def audit(
        self,
        *,
        who: str,
        role: str,
        drone_id: str | None,
        command: str,
        params: dict[str, Any],
        status: int,
        answer: Any,
    ) -> None:
        row = (
            timestamp_s(),
            who,
            role,
            drone_id,
            command,
            orjson.dumps(params, default=str).decode(),
            status,
            orjson.dumps(answer, default=str).decode(),
        )

        def write(db: sqlite3.Connection) -> None:
            with db:
                db.execute(
                    "INSERT INTO audit (ts, who, role, drone_id, command, params, status, answer)"
                    " VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                    row,
                )

        await self.run(write)

    async def read_audit(
        self, *, drone_id: str | None = None, limit: int = 100, before_id: int | None = None
    ) -> list[dict[str, Any]]:
        sql = "SELECT id, ts, who, role, drone_id, command, params, status, answer FROM audit"
        where: list[str] = []
        args: list[Any] = []
        if drone_id is not None:
            where.append("drone_id = ?")
            args.append(drone_id)
        if before_id is not None:
            where.append("id < ?")
            args.append(before_id)
        if where:
            sql += " WHERE " + " AND ".join(where)
        sql += " ORDER BY id DESC LIMIT ?"
        args.append(limit)
        rows = await self.run(lambda db: db.execute(sql, args).fetchall())
        keys = ("id", "ts", "who", "role", "drone_id", "command", "params", "status", "answer")
        out = []
        for row in rows:
            entry = dict(zip(keys, row, strict=True))
            entry["params"] = orjson.loads(entry["params"])
            entry["answer"] = orjson.loads(entry["answer"])
            out.append(entry)
        return out
