"""Opening the ground's SQLite files (``--state``, ``--store sqlite:///``) safely.

A file named on the command line may be anything: garbage, another program's database, an older
ground's. Two things go wrong with such a file unless they are handled here:

- aiosqlite's connection thread is not a daemon, so a connection left open when its set-up
  fails keeps the process from ever exiting (the ground hung after printing a traceback);
- ``CREATE TABLE IF NOT EXISTS`` keeps a table of the same name that is not ours, and the
  first query on it fails later, far from the cause ("no such column: name").

So the set-up runs inside :func:`closed_unless_opened`, and every script's tables are checked
against what the script itself makes, with :func:`refuse_foreign_tables`. Both refusals are
:class:`~dronefleet.errors.InvalidInput` naming the option, which every command prints in one line.
"""

from __future__ import annotations

import contextlib
import functools
import sqlite3
from collections.abc import AsyncIterator

import aiosqlite

from dronefleet.errors import InvalidInput
from dronefleet.virtual_loop import held


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
