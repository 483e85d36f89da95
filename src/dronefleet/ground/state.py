"""The ground state store (docs/DESIGN.md §7): drones seen, API tokens, the audit log of every
command.

SQLite in WAL mode through aiosqlite (a kept library: one connection on a thread of its own, so
the event loop never blocks on disk; it replaced our own thread-and-executor wrapper). Each call
is awaited through ``virtual_loop.held``: on a simulation's virtual loop, time stands still while
the disk works (aiosqlite's thread is invisible to the loop otherwise, and vehicle seconds would
pass during a write — a figure that moves with load, issue 9). The Drone
Identifier keeps its fleet here so a restart remembers it; the Drone Manager keeps tokens (hashed)
and the audit log (the seed's logging requirement 3.1.6); what each drone was measured to draw
per airframe is kept for the planner (issue 28: ground/planner/airframe_draws.py). Later rooms
(the Mission Planner) add their own tables through :meth:`StateStore.script`, :meth:`write`
and :meth:`rows`.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any, TypeVar

import aiosqlite
import orjson

from dronefleet.clock import timestamp_s
from dronefleet.ground.sqlite_file import open_sqlite, refuse_foreign_tables
from dronefleet.owner_only import private_file
from dronefleet.virtual_loop import held

SCHEMA = """
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
CREATE TABLE IF NOT EXISTS airframe_draws (
    airframe TEXT NOT NULL,
    drone_id TEXT NOT NULL,
    draw_a REAL NOT NULL,
    updated_at REAL NOT NULL,
    PRIMARY KEY (airframe, drone_id)
);
"""


async def _roll_back(db: aiosqlite.Connection) -> None:
    """End a transaction that failed or was cancelled half way. Statements already queued on
    the connection's thread still run, so the rollback is queued after them, shielded from a
    second cancellation; with no transaction open it does nothing (sqlite3's rollback)."""
    with contextlib.suppress(Exception):
        await held(asyncio.shield(db.rollback()))


def _owner_only(path: Path) -> None:
    """Token hashes and the audit log: the owner's only (SQLite gives its -wal and -shm files
    the database's mode); a folder made for it is the owner's only too."""
    private_file(path)


_INT_RANGE = range(-(2**63), 2**64)  # what orjson writes as a number


def _json(value: Any) -> str:
    """``value`` as JSON text for an audit row. What the caller sent is kept as sent, except
    what JSON-in-SQLite cannot hold as is: an integer past 64 bits (``10**30`` in a step) is
    kept as its digits, a non-string key as text (issue 25: such a refusal lost its row)."""
    try:
        return orjson.dumps(value, default=str).decode()
    except TypeError:
        return orjson.dumps(_storable(value), default=str).decode()


def _storable(value: Any) -> Any:
    if isinstance(value, bool):
        return value
    if isinstance(value, int):
        return value if value in _INT_RANGE else str(value)
    if isinstance(value, dict):
        return {str(k): _storable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_storable(v) for v in value]
    return value


H = TypeVar("H")


def opened(handle: H | None) -> H:
    """A state store's ``handle`` (its connection, or pool) once the store is open."""
    if handle is None:
        raise RuntimeError("state store is not open")
    return handle


class StateStore:
    """One SQLite file (``:memory:`` for tests)."""

    def __init__(self, path: str | Path) -> None:
        self.path = str(path)
        self._db: aiosqlite.Connection | None = None
        self._writing = asyncio.Lock()  # one transaction at a time on the one connection

    async def open(self) -> StateStore:
        if self.path != ":memory:":
            await asyncio.to_thread(_owner_only, Path(self.path))
        self._db = await open_sqlite(self.path, SCHEMA, self._what)
        return self

    async def close(self) -> None:
        if self._db is not None:
            db, self._db = self._db, None
            await held(db.close())

    @property
    def db(self) -> aiosqlite.Connection:
        return opened(self._db)

    @property
    def _what(self) -> str:
        return f"--state {self.path}"

    async def script(self, sql: str) -> None:
        """Run a script (a room's ``CREATE TABLE IF NOT EXISTS ...``); a table of one of its
        names that is not the ground's is refused (sqlite_file.py)."""
        async with self._writing:
            await refuse_foreign_tables(self.db, sql, self._what)
            await held(self.db.executescript(sql))

    async def write(self, *statements: tuple[str, Sequence[Any]]) -> list[int]:
        """Run ``(sql, args)`` statements in one transaction; each one's row count."""
        async with self._writing:
            try:
                await held(self.db.execute("BEGIN"))
                counts = [(await held(self.db.execute(q, args))).rowcount for q, args in statements]
                await held(self.db.execute("COMMIT"))
            except BaseException:
                await _roll_back(self.db)
                raise
            return counts

    async def write_many(self, sql: str, rows: Iterable[Sequence[Any]]) -> None:
        async with self._writing:
            try:
                await held(self.db.execute("BEGIN"))
                await held(self.db.executemany(sql, rows))
                await held(self.db.execute("COMMIT"))
            except BaseException:
                await _roll_back(self.db)
                raise

    async def rows(self, sql: str, args: Sequence[Any] = ()) -> list[Any]:
        cursor = await held(self.db.execute(sql, args))
        try:
            return list(await held(cursor.fetchall()))
        finally:
            await held(cursor.close())

    async def columns(self, table: str) -> set[str]:
        """The names of ``table``'s columns (a room adding one to an older database)."""
        if not table.isidentifier():
            raise ValueError(f"not a table name: {table!r}")
        return {row[1] for row in await self.rows(f"PRAGMA table_info({table})")}

    async def problem(self) -> str | None:
        """Why the store cannot be used now, or None (a file: its disk is watched instead)."""
        return None

    @property
    def shared(self) -> bool:
        """Whether other ground replicas may use the same state (a database server)."""
        return False

    # -- drones --------------------------------------------------------------------------------
    async def save_drones(self, records: list[dict[str, Any]]) -> None:
        now = timestamp_s()
        rows = [(r["drone_id"], orjson.dumps(r).decode(), now) for r in records]
        await self.write_many(
            "INSERT INTO drones (drone_id, record, updated_at) VALUES (?, ?, ?) "
            "ON CONFLICT (drone_id) DO UPDATE SET record = excluded.record, "
            "updated_at = excluded.updated_at",
            rows,
        )

    async def load_drones(self) -> list[dict[str, Any]]:
        rows = await self.rows("SELECT record FROM drones ORDER BY drone_id")
        return [orjson.loads(r[0]) for r in rows]

    # -- the fleet's measured draw per airframe (ground/planner/airframe_draws.py) -------------
    async def save_airframe_draws(self, rows: list[tuple[str, str, float]]) -> None:
        """``(airframe, drone_id, amperes)``: what each drone was last measured to draw."""
        now = timestamp_s()
        await self.write_many(
            "INSERT INTO airframe_draws (airframe, drone_id, draw_a, updated_at) "
            "VALUES (?, ?, ?, ?) ON CONFLICT (airframe, drone_id) DO UPDATE SET "
            "draw_a = excluded.draw_a, updated_at = excluded.updated_at",
            [(*row, now) for row in rows],
        )

    async def load_airframe_draws(self) -> list[tuple[str, str, float]]:
        rows = await self.rows("SELECT airframe, drone_id, draw_a FROM airframe_draws")
        return [(str(a), str(d), float(w)) for a, d, w in rows]

    # -- tokens --------------------------------------------------------------------------------
    async def add_token(self, token_hash: str, name: str, role: str) -> None:
        """The token called ``name`` is now ``token_hash`` (an earlier one of that name goes).

        One upsert on the name, not a delete then an insert: grounds starting at once on one
        PostgreSQL state both inserted their token, and the second died on a unique key (the
        same ``--token``: the primary key; each its own first-start admin token: the name)."""
        await self.write(
            ("DELETE FROM tokens WHERE token_hash = ? AND name <> ?", (token_hash, name)),
            (
                "INSERT INTO tokens (token_hash, name, role, created_at) VALUES (?, ?, ?, ?) "
                "ON CONFLICT (name) DO UPDATE SET token_hash = excluded.token_hash, "
                "role = excluded.role, created_at = excluded.created_at",
                (token_hash, name, role, timestamp_s()),
            ),
        )

    async def add_token_if_none(self, token_hash: str, name: str, role: str) -> bool:
        """Add the token called ``name`` unless there is one; whether it was added (a ground's
        first start issues its tokens so: of two starting at once, one issues them, and the
        other does not show a token that the first then replaced)."""
        (added,) = await self.write(
            (
                "INSERT INTO tokens (token_hash, name, role, created_at) VALUES (?, ?, ?, ?) "
                "ON CONFLICT (name) DO NOTHING",
                (token_hash, name, role, timestamp_s()),
            ),
        )
        return added == 1

    async def find_token(self, token_hash: str) -> tuple[str, str] | None:
        rows = await self.rows("SELECT name, role FROM tokens WHERE token_hash = ?", (token_hash,))
        return (rows[0][0], rows[0][1]) if rows else None

    async def list_tokens(self) -> list[dict[str, Any]]:
        rows = await self.rows("SELECT name, role, created_at FROM tokens ORDER BY created_at")
        return [{"name": n, "role": r, "created_at": c} for n, r, c in rows]

    async def delete_token(self, name: str) -> bool:
        (deleted,) = await self.write(("DELETE FROM tokens WHERE name = ?", (name,)))
        return deleted > 0

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
            _json(params),
            status,
            _json(answer),
        )

        await self.write(
            (
                "INSERT INTO audit (ts, who, role, drone_id, command, params, status, answer)"
                " VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                row,
            )
        )

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
        rows = await self.rows(sql, args)
        keys = ("id", "ts", "who", "role", "drone_id", "command", "params", "status", "answer")
        out = []
        for row in rows:
            entry = dict(zip(keys, row, strict=True))
            entry["params"] = orjson.loads(entry["params"])
            entry["answer"] = orjson.loads(entry["answer"])
            out.append(entry)
        return out
