"""PostgreSQL for tests (issue 27): the machine's server, or one of the test's own.

CI machines run PostgreSQL on 127.0.0.1:5432 with trust authentication
(``DRONEFLEET_TEST_POSTGRES`` names another server); each test gets a fresh database there,
dropped after. A test that must stop the database (a replica losing it) starts its own cluster
with Debian's ``initdb`` and ``pg_ctl`` on a free port (scripts/system-deps.sh installs them);
as root, the server runs as the ``postgres`` user, which PostgreSQL insists on.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import pwd
import secrets
import shutil
import subprocess
import tempfile
from collections.abc import AsyncIterator, Iterator
from pathlib import Path

import asyncpg

from dronefleet.messaging.embedded import free_port
from support.brokers import wait_port

SHARED = os.environ.get("DRONEFLEET_TEST_POSTGRES", "postgresql://postgres@127.0.0.1:5432/postgres")


def _bin(name: str) -> str:
    found = shutil.which(name)
    if found:
        return found
    versions = sorted(Path("/usr/lib/postgresql").glob(f"*/bin/{name}"))
    if not versions:
        raise RuntimeError(f"{name} not found: run scripts/system-deps.sh (Debian's postgresql)")
    return str(versions[-1])


async def _admin(server: str, sql: str) -> None:
    con = await asyncpg.connect(server, timeout=10)
    try:
        await con.execute(sql)
    finally:
        await con.close()


async def _create(server: str, prefix: str) -> tuple[str, str]:
    """A new empty database on ``server``: its name and URL."""
    name = f"{prefix}_{secrets.token_hex(5)}"
    await _admin(server, f'CREATE DATABASE "{name}"')
    return name, f"{server.rsplit('/', 1)[0]}/{name}"


async def _drop(server: str, name: str) -> None:
    with contextlib.suppress(Exception):
        await _admin(server, f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')


@contextlib.contextmanager
def fresh_database(server: str = SHARED, prefix: str = "dronefleet_test") -> Iterator[str]:
    """A new empty database on ``server``; its URL. Dropped after."""
    name, url = asyncio.run(_create(server, prefix))
    try:
        yield url
    finally:
        asyncio.run(_drop(server, name))


@contextlib.asynccontextmanager
async def fresh_database_async(
    server: str = SHARED, prefix: str = "dronefleet_test"
) -> AsyncIterator[str]:
    """:func:`fresh_database` inside an event loop (bench/scale_out.py)."""
    name, url = await _create(server, prefix)
    try:
        yield url
    finally:
        await _drop(server, name)


class OwnPostgres:
    """A PostgreSQL cluster of the test's own on a free loopback port: start, kill, start."""

    def __init__(self, folder: Path) -> None:
        self.port = free_port()
        # Its own folder under the system's temporary one: pytest's are the owner's only, and
        # the server runs as another user when the tests run as root.
        self.folder = Path(tempfile.mkdtemp(prefix=f"dronefleet-pg-{self.port}-"))
        self.data = self.folder / "data"
        self.log = self.folder / "server.log"
        self._as: list[str] = []
        self.data.mkdir()
        if os.geteuid() == 0:  # initdb and postgres refuse to run as root
            self._as = ["runuser", "-u", "postgres", "--"]
            user = pwd.getpwnam("postgres")
            os.chown(self.folder, user.pw_uid, user.pw_gid)
            os.chown(self.data, user.pw_uid, user.pw_gid)
        subprocess.run(
            [*self._as, _bin("initdb"), "-D", str(self.data), "-U", "postgres",
             "--auth=trust", "-E", "UTF8", "--no-sync"],
            check=True, capture_output=True, cwd="/",
        )  # fmt: skip
        (self.data / "postgresql.auto.conf").write_text(
            f"listen_addresses = '127.0.0.1'\nport = {self.port}\n"
            f"unix_socket_directories = ''\nfsync = off\n"
        )

    @property
    def url(self) -> str:
        return f"postgresql://postgres@127.0.0.1:{self.port}/postgres"

    def start(self) -> None:
        subprocess.run(
            [*self._as, _bin("pg_ctl"), "-D", str(self.data), "-l", str(self.log), "-w",
             "-t", "60", "start"],
            check=True, capture_output=True, cwd="/",
        )  # fmt: skip
        wait_port("127.0.0.1", self.port, 30)

    def stop(self, mode: str = "fast") -> None:
        """``immediate`` is as near a crash as pg_ctl gets (no checkpoint, connections cut)."""
        subprocess.run(
            [*self._as, _bin("pg_ctl"), "-D", str(self.data), "-m", mode, "-w", "stop"],
            check=False, capture_output=True,
        )  # fmt: skip


@contextlib.contextmanager
def own_postgres(folder: Path) -> Iterator[OwnPostgres]:
    server = OwnPostgres(folder)
    server.start()
    try:
        yield server
    finally:
        server.stop("immediate")
        shutil.rmtree(server.folder, ignore_errors=True)
