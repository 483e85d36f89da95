"""Map imagery from a local MBTiles file, for web maps in the field without a network (issue 14).

``--tiles field.mbtiles`` (ground and demo) serves the file's tiles at
``/api/v1/tiles/{z}/{x}/{y}`` and its metadata at ``/api/v1/tiles``. An MBTiles file (spec 1.3)
is SQLite: ``metadata`` (name/value rows: ``format``, ``bounds``, ``center``, ``minzoom``,
``maxzoom``...) and ``tiles`` (``zoom_level``, ``tile_column``, ``tile_row``, ``tile_data``),
rows numbered in TMS order (row 0 at the south), so the XYZ ``y`` of a web map is flipped.

The file is opened read-only (a ground never alters its imagery) through aiosqlite, which runs
every query on a thread of its own: the event loop serving the brokers and HTTP never waits on
the disk. Raster tiles only (png, jpg, webp): Leaflet draws images, a vector (pbf) set is
refused at start with the reason. No MBTiles library is used: the ones on PyPI are
synchronous readers or whole tile servers; the format is two SQL queries.
"""

from __future__ import annotations

import asyncio
import math
from pathlib import Path
from urllib.parse import quote

import aiosqlite
from pydantic import BaseModel, Field

from dronefleet.errors import InvalidInput

#: The raster formats a web map draws, with their media types.
MEDIA_TYPES = {"png": "image/png", "jpg": "image/jpeg", "jpeg": "image/jpeg", "webp": "image/webp"}
#: How each one starts, for a file whose metadata does not name its format.
MAGIC = {b"\x89PNG": "png", b"\xff\xd8\xff": "jpg", b"RIFF": "webp"}
MAX_ZOOM = 30


def is_tile_url(text: str) -> bool:
    """Whether ``--tiles`` names a tile server (a URL template) rather than an MBTiles file."""
    return text.startswith(("http://", "https://"))


class MBTilesError(InvalidInput):
    """A file that is not a raster MBTiles set this ground can serve; the reason says why."""


class TileSet(BaseModel):
    """What the web map needs of an MBTiles file: where it is, at which zooms, what it is."""

    name: str
    format: str = Field(description="png, jpg or webp")
    bounds: list[float] | None = Field(
        default=None, description="[west, south, east, north] in degrees (WGS84)"
    )
    center: list[float] | None = Field(default=None, description="[lon, lat, zoom]")
    min_zoom: int
    max_zoom: int
    attribution: str | None = None
    description: str | None = None
    tiles: int = Field(description="how many tiles the file holds")


class MBTiles:
    """An MBTiles file opened read-only: ``await MBTiles.open(path)``, then :meth:`tile`."""

    def __init__(self, path: Path, db: aiosqlite.Connection, tileset: TileSet) -> None:
        self.path = path
        self._db = db
        self.tileset = tileset

    @property
    def media_type(self) -> str:
        return MEDIA_TYPES[self.tileset.format]

    @classmethod
    async def open(cls, path: str | Path) -> MBTiles:
        path = Path(path)
        try:
            # Read first: a file that cannot be read is refused before aiosqlite starts a
            # thread for it (a failed connect leaves that thread a stop to answer on a loop that
            # may be closed by then: omnilib/aiosqlite#389).
            await asyncio.to_thread(_readable, path)
            # A URI, for mode=ro: SQLite reads relative "file:" paths too.
            db = await aiosqlite.connect(f"file:{quote(str(path))}?mode=ro", uri=True)
        except Exception as exc:  # sqlite3 says "unable to open database file"
            raise MBTilesError(f"{path} cannot be opened: {exc}") from exc
        try:
            tileset = await _read_tileset(db, path)
        except BaseException:
            await db.close()
            raise
        return cls(path, db, tileset)

    async def tile(self, z: int, x: int, y: int) -> bytes | None:
        """The tile at XYZ ``z/x/y`` (as web maps number them), or None where the file has none."""
        if not 0 <= z <= MAX_ZOOM or not (0 <= x < 2**z and 0 <= y < 2**z):
            return None
        row = (1 << z) - 1 - y  # TMS rows count from the south
        async with self._db.execute(
            "SELECT tile_data FROM tiles WHERE zoom_level = ? AND tile_column = ? AND tile_row = ?",
            (z, x, row),
        ) as cursor:
            found = await cursor.fetchone()
        return bytes(found[0]) if found and found[0] is not None else None

    async def close(self) -> None:
        await self._db.close()


def _readable(path: Path) -> None:
    """Raise the OSError (missing, a folder, not allowed) that opening ``path`` would."""
    with path.open("rb"):
        pass


async def _read_tileset(db: aiosqlite.Connection, path: Path) -> TileSet:
    import sqlite3

    try:
        async with db.execute("SELECT name, value FROM metadata") as cursor:
            meta = {str(k): str(v) for k, v in await cursor.fetchall() if k is not None}
        async with db.execute(
            "SELECT min(zoom_level), max(zoom_level), count(*) FROM tiles"
        ) as cursor:
            row = await cursor.fetchone()
    except sqlite3.DatabaseError as exc:
        raise MBTilesError(f"{path} is not an MBTiles file ({exc})") from exc
    low, high, count = row if row else (None, None, 0)
    if not count:
        raise MBTilesError(f"{path} holds no tiles")
    fmt = meta.get("format", "").lower() or await _sniff_format(db)
    if fmt == "pbf":
        raise MBTilesError(f"{path} holds vector tiles (pbf); the web map draws raster tiles")
    if fmt not in MEDIA_TYPES:
        raise MBTilesError(f"{path}: tile format {fmt!r} is not png, jpg or webp")
    return TileSet(
        name=meta.get("name") or path.stem,
        format="jpg" if fmt == "jpeg" else fmt,
        bounds=_numbers(meta.get("bounds"), 4, path, "bounds"),
        center=_numbers(meta.get("center"), 3, path, "center"),
        min_zoom=_zoom(meta.get("minzoom"), low),
        max_zoom=_zoom(meta.get("maxzoom"), high),
        attribution=meta.get("attribution"),
        description=meta.get("description"),
        tiles=int(count),
    )


async def _sniff_format(db: aiosqlite.Connection) -> str:
    async with db.execute("SELECT tile_data FROM tiles LIMIT 1") as cursor:
        row = await cursor.fetchone()
    data = bytes(row[0]) if row and row[0] is not None else b""
    return next((fmt for magic, fmt in MAGIC.items() if data.startswith(magic)), "unknown")


def _numbers(text: str | None, count: int, path: Path, name: str) -> list[float] | None:
    """``bounds`` (4 numbers) or ``center`` (3; 2 are taken too): None when absent."""
    if not text:
        return None
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise MBTilesError(f"{path}: metadata {name} {text!r} is not numbers") from None
    if name == "center" and len(values) == 2:
        values.append(math.nan)
    if len(values) != count or not all(math.isfinite(v) for v in values[:2]):
        raise MBTilesError(f"{path}: metadata {name} {text!r} needs {count} numbers")
    return [v for v in values if math.isfinite(v)]


def _zoom(text: str | None, found: int | None) -> int:
    """A zoom from the metadata, else the one the tiles have."""
    try:
        return max(0, min(MAX_ZOOM, int(text))) if text else int(found or 0)
    except ValueError:
        return int(found or 0)
