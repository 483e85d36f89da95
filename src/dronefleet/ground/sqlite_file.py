"""Opening the ground's SQLite files (``--state``, ``--store sqlite:///``) safely.

A file named on the command line may be anything: garbage, another program's database, an older
ground's. Two things go wrong with such a file unless they are handled here:

- aiosqlite's connection thread is not a daemon, so a connection left open when its set-up
  fails keeps the process from ever exiting (the ground hung after printing a traceback);
- ``CREATE TABLE IF NOT EXISTS`` keeps a table of the same name that is not ours, and the
  first query on it fails later, far from the cause ("no such column: name").

So both stores open their file with :func:`open_sqlite`, which sets it up inside
:func:`closed_unless_opened` and first checks the schema's tables against what the script itself
makes (:func:`refuse_foreign_tables`, also run before each room's script). Both refusals are
:class:`~dronefleet.errors.InvalidInput` naming the option, which every command prints in one
line.
"""

from __future__ import annotations

import contextlib
import functools
import sqlite3
from collections.abc import AsyncIterator, Awaitable, Callable

import aiosqlite

from dronefleet.errors import InvalidInput
from dronefleet.virtual_loop import held


async def open_sqlite(
    path: str,
    schema: str,
    what: str,
    *,
    upgrade: Callable[[aiosqlite.Connection], Awaitable[None]] | None = None,
) -> aiosqlite.Connection:
    """``path`` opened in WAL mode with ``schema`` made: refused as ``what`` (nothing written)
    if it is not a database or holds a table of ours that is not ours; ``upgrade`` runs before
    the schema (an earlier version's tables renamed)."""
    db = await held(aiosqlite.connect(path, isolation_level=None))
    async with closed_unless_opened(db, what):
        await refuse_foreign_tables(db, schema, what)  # before the file is changed
        await held(db.execute("PRAGMA journal_mode=WAL"))
        await held(db.execute("PRAGMA synchronous=NORMAL"))
        if upgrade is not None:
            await upgrade(db)
        await held(db.executescript(schema))
    return db


@contextlib.asynccontextmanager
async def closed_unless_opened(db: aiosqlite.Connection, what: str) -> AsyncIterator[None]:
    """Close ``db`` if its set-up fails; a file that is not a database is refused as ``what``."""
    try:
        yield
    except BaseException as exc:
        await held(db.close())
        if isinstance(exc, sqlite3.DatabaseError):
            raise InvalidInput(f"{what} cannot be used: {exc}") from exc
        raise


@functools.cache
def tables_made_by(script: str) -> dict[str, frozenset[str]]:
    """Each table ``script`` makes and its columns, as SQLite itself reads the script (on a
    scratch database in memory: no parser of our own)."""
    with contextlib.closing(sqlite3.connect(":memory:")) as scratch:
        scratch.executescript(script)
        names = [
            row[0]
            for row in scratch.execute(
                "SELECT name FROM sqlite_master WHERE type = 'table' AND name NOT LIKE 'sqlite_%'"
            )
        ]
        return {
            name: frozenset(row[1] for row in scratch.execute(f'PRAGMA table_info("{name}")'))
            for name in names
        }


async def refuse_foreign_tables(db: aiosqlite.Connection, script: str, what: str) -> None:
    """Refuse a file that has a table of a name ``script`` uses without a column the script gives
    it; run before the script, so a refused file is left as it was. Columns added since (a later
    ``ALTER TABLE``) are the file's own business."""
    for table, columns in tables_made_by(script).items():
        cursor = await held(db.execute(f'PRAGMA table_info("{table}")'))
        try:
            found = {row[1] for row in await held(cursor.fetchall())}
        finally:
            await held(cursor.close())
        if found and (missing := sorted(columns - found)):  # none found: not made yet
            raise InvalidInput(
                f"{what} cannot be used: its table {table} is not the ground's (it has no "
                f"{', '.join(missing)}); is it another program's file?"
            )
