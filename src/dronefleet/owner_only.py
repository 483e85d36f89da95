"""Files only their owner may read (issue 25): what the ground, a drone or the simulator writes.

Telemetry, audit logs, flight logs and pictures tell where drones fly and who commands them; on
a shared machine no other account has reason to read them. The processes of ``dronefleet
ground``, ``drone``, ``sim`` and ``demo`` set :func:`private_umask` at start, so everything they
and their libraries (SQLite's -wal and -shm files included) create is 0600 and every folder 0700.
The writers also ask for those modes themselves (a library used in another process, a file left
by an earlier version): :func:`make_dir`, :func:`private_file`, :func:`open_private`,
:func:`write_private`. A folder that already exists (the working directory, a folder the user
named) is left as it is: only the folders made here are 0700.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path
from typing import BinaryIO

FILE_MODE = 0o600
DIR_MODE = 0o700


def private_umask() -> int:
    """Everything this process creates from now on is its owner's only; the previous umask."""
    return os.umask(0o077)


def make_dir(path: Path) -> Path:
    """``path`` and every missing folder above it, each made 0700."""
    missing = []
    at = path
    while not at.exists():
        missing.append(at)
        if at.parent == at:
            break
        at = at.parent
    for folder in reversed(missing):
        with contextlib.suppress(FileExistsError):  # made meanwhile by another writer
            folder.mkdir(mode=DIR_MODE)
    return path


def private_file(path: Path) -> Path:
    """``path`` exists and is 0600 (made empty if missing; one left 0644 by an earlier version
    is closed to others), e.g. a database before SQLite opens it: its -wal and -shm files get
    the database's mode."""
    make_dir(path.parent)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT, FILE_MODE)
    try:
        os.fchmod(fd, FILE_MODE)
    finally:
        os.close(fd)
    return path


def open_private(path: Path, *, append: bool = False) -> BinaryIO:
    """``path`` opened for binary writing (truncated, or appended to), 0600 whatever it was."""
    make_dir(path.parent)
    flags = os.O_WRONLY | os.O_CREAT | (os.O_APPEND if append else os.O_TRUNC)
    fd = os.open(path, flags, FILE_MODE)
    try:
        os.fchmod(fd, FILE_MODE)
        return open(fd, "ab" if append else "wb")
    except BaseException:
        os.close(fd)
        raise


def write_private(path: Path, data: bytes) -> None:
    """``path`` holds ``data``, 0600: written beside it and renamed into place, so a reader
    never sees half of it."""
    part = path.with_name(path.name + ".part")
    with open_private(part) as out:
        out.write(data)
    os.replace(part, path)
