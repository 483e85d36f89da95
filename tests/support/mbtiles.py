"""MBTiles files for the tests (spec 1.3), built with the standard library's sqlite3 and Pillow.

Each tile is a real PNG of one colour, a different colour per tile, so a test can tell by its
pixels which tile a map drew (and that the TMS row flip put it in the right place).
"""

from __future__ import annotations

import io
import math
import sqlite3
from pathlib import Path

from PIL import Image


def tile_of(lat: float, lon: float, z: int) -> tuple[int, int]:
    """The XYZ (slippy-map) tile (x, y) holding lat, lon at zoom z."""
    n = 2**z
    x = int((lon + 180) / 360 * n)
    y = int((1 - math.asinh(math.tan(math.radians(lat))) / math.pi) / 2 * n)
    return x, y


def tile_bounds(z: int, x: int, y: int) -> tuple[float, float, float, float]:
    """[west, south, east, north] of XYZ tile z/x/y in degrees."""
    n = 2**z

    def lat(row: int) -> float:
        return math.degrees(math.atan(math.sinh(math.pi * (1 - 2 * row / n))))

    return x / n * 360 - 180, lat(y + 1), (x + 1) / n * 360 - 180, lat(y)


def colour_of(z: int, x: int, y: int) -> tuple[int, int, int]:
    """A colour per tile, told apart by its pixels."""
    return (40 + (x * 37) % 200, 40 + (y * 53) % 200, 40 + (z * 29) % 200)


def image(rgb: tuple[int, int, int], fmt: str = "png", size: int = 256) -> bytes:
    out = io.BytesIO()
    Image.new("RGB", (size, size), rgb).save(out, {"jpg": "JPEG"}.get(fmt, fmt.upper()))
    return out.getvalue()


def build(
    path: Path,
    centre: tuple[float, float],
    zooms: range,
    *,
    radius: int = 1,
    fmt: str = "png",
    metadata: dict[str, str] | None = None,
) -> dict[tuple[int, int, int], tuple[int, int, int]]:
    """An MBTiles file with, at each zoom, the (2r+1)^2 tiles around ``centre`` (lat, lon).

    Rows are written in TMS order (flipped), as the spec says. Returns XYZ key -> colour."""
    colours: dict[tuple[int, int, int], tuple[int, int, int]] = {}
    db = sqlite3.connect(path)
    db.execute("CREATE TABLE metadata (name TEXT, value TEXT)")
    db.execute(
        "CREATE TABLE tiles (zoom_level INTEGER, tile_column INTEGER, tile_row INTEGER, "
        "tile_data BLOB)"
    )
    db.execute("CREATE UNIQUE INDEX tile_index ON tiles (zoom_level, tile_column, tile_row)")
    for z in zooms:
        cx, cy = tile_of(*centre, z)
        for x in range(cx - radius, cx + radius + 1):
            for y in range(cy - radius, cy + radius + 1):
                colours[(z, x, y)] = colour_of(z, x, y)
                row = 2**z - 1 - y
                db.execute(
                    "INSERT INTO tiles VALUES (?, ?, ?, ?)",
                    (z, x, row, image(colours[(z, x, y)], fmt)),
                )
    # The bounds of the tiles at the deepest zoom, a hair inside (a map must not ask for the
    # tile beyond an edge by rounding): every tile a map asks inside them is in the file.
    z = zooms[-1]
    cx, cy = tile_of(*centre, z)
    west, south, _, _ = tile_bounds(z, cx - radius, cy + radius)
    _, _, east, north = tile_bounds(z, cx + radius, cy - radius)
    hair = (east - west) / (2 * radius + 1) / 100
    west, south, east, north = west + hair, south + hair, east - hair, north - hair
    meta = {
        "name": "test field",
        "format": fmt,
        "bounds": f"{west},{south},{east},{north}",
        "center": f"{centre[1]},{centre[0]},{zooms[-1]}",
        "minzoom": str(zooms[0]),
        "maxzoom": str(zooms[-1]),
        "attribution": "tests",
        **(metadata or {}),
    }
    db.executemany("INSERT INTO metadata VALUES (?, ?)", [(k, v) for k, v in meta.items() if v])
    db.commit()
    db.close()
    return colours
