"""The map without a tile server (an offline grid, loopback only), with one (`--tiles URL`), and
with a local MBTiles file (`--tiles FILE.mbtiles`): real tile images drawn from the file."""

from __future__ import annotations

import math
import re
import struct
import zlib
from urllib.parse import urlsplit

import pytest

from support.http_stub import HttpStub
from support.mbtiles import build

from .conftest import ARTIFACTS, get, start_demo

pytestmark = pytest.mark.e2e

LOOPBACK = {"127.0.0.1", "localhost"}


def loaded_urls(page) -> list[str]:
    return page.evaluate("performance.getEntriesByType('resource').map((e) => e.name)")


def test_without_a_tile_url_the_map_draws_the_offline_grid(open_page, demo):
    assert get(demo, "/web/config") == {"tiles": None, "local_tiles": False}
    page, console = open_page("fleet")
    requests: list[str] = []
    page.on("request", lambda r: requests.append(r.url))
    page.wait_for_selector("#fleet-map[data-ready='1'] .leaflet-tile-container canvas.leaflet-tile")
    page.click("#fleet-map .leaflet-control-zoom-out")  # a new zoom level: new grid tiles
    page.wait_for_function(
        "() => document.querySelectorAll('#fleet-map canvas.leaflet-tile').length >= 4",
        timeout=10_000,
    )
    assert page.locator("#fleet-map img.leaflet-tile").count() == 0
    # The grid: a light fill with a line every 64 px.
    fill, line = page.evaluate(
        """() => {
             const g = document.querySelector('#fleet-map canvas.leaflet-tile').getContext('2d');
             return [[10, 10], [64, 10]].map(([x, y]) => [...g.getImageData(x, y, 1, 1).data]);
           }"""
    )
    assert fill == [244, 246, 248, 255] and line == [221, 226, 231, 255], (fill, line)
    hosts = {urlsplit(u).hostname for u in [*loaded_urls(page), *requests]}
    assert hosts <= LOOPBACK, f"requests left the machine: {hosts}"
    # The grid alone says on the map how to get imagery (issue 29).
    assert page.inner_text("#fleet-map-no-tiles") == (
        "no map tiles: start the ground with --tiles FILE.mbtiles"
    )
    console.assert_clean()


def png(width: int = 256, height: int = 256, rgb: tuple[int, int, int] = (170, 211, 223)) -> bytes:
    """A plain PNG: signature, IHDR, one zlib IDAT of filter-0 rows, IEND."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (
            struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
        )

    rows = b"".join(b"\0" + bytes(rgb) * width for _ in range(height))
    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)  # 8-bit RGB
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"IDAT", zlib.compress(rows))
        + chunk(b"IEND", b"")
    )


class TileServer(HttpStub):
    """A loopback HTTP server answering every GET with one PNG; it keeps the paths asked for."""

    def __init__(self) -> None:
        self.paths: list[str] = []
        body = png()

        def answer(path: str, _headers: dict[str, str]) -> tuple[int, str, bytes]:
            self.paths.append(path)
            return 200, "image/png", body

        super().__init__(answer)


def tile_of(lat: float, lon: float, z: int) -> tuple[int, int]:
    """The slippy-map tile (x, y) holding lat, lon at zoom z."""
    n = 2**z
    x = int((lon + 180) / 360 * n)
    y = int((1 - math.asinh(math.tan(math.radians(lat))) / math.pi) / 2 * n)
    return x, y


def test_with_a_tile_url_the_map_loads_tiles_from_it(open_page, tmp_path):
    tiles = TileServer()
    template = f"{tiles.url}/{{z}}/{{x}}/{{y}}.png"
    server = start_demo(tmp_path, "--drones", "1", "--tiles", template)
    try:
        assert get(server, "/web/config") == {"tiles": template, "local_tiles": False}
        page, console = open_page("fleet", server=server)
        page.wait_for_selector("#fleet-map img.leaflet-tile-loaded", timeout=20_000)
        page.wait_for_selector("#fleet-table tr[data-drone='QUAD_1']")
        where = get(server, "/drones/QUAD_1")["position"]
        asked = [re.fullmatch(r"/(\d+)/(\d+)/(\d+)\.png", p) for p in list(tiles.paths)]
        assert asked and all(asked), f"not /z/x/y.png: {tiles.paths}"
        found = {tuple(int(v) for v in m.groups()) for m in asked}
        assert all(z <= 19 for z, _, _ in found), found  # maxNativeZoom: no deeper
        assert any((z, *tile_of(where["lat"], where["lon"], z)) in found for z, _, _ in found), (
            f"no tile under the drone at {where}: {sorted(found)}"
        )
        # The offline grid stays underneath; nothing but loopback was asked.
        assert page.locator("#fleet-map canvas.leaflet-tile").count() > 0
        assert {urlsplit(u).hostname for u in loaded_urls(page)} <= LOOPBACK
        assert page.locator("#fleet-map-no-tiles").count() == 0
        console.assert_clean()
    finally:
        server.stop()
        tiles.close()


def test_with_an_mbtiles_file_the_map_draws_its_tiles(open_page, tmp_path):
    """Issue 14: in the field without a network. The ground serves the file's tiles (with the
    page's credentials), and the map draws them where the file says, at its centre and zooms."""
    home = (40.63, -8.659)
    colours = build(tmp_path / "field.mbtiles", home, range(16, 19), radius=2)
    server = start_demo(tmp_path, "--drones", "1", "--tiles", str(tmp_path / "field.mbtiles"))
    try:
        assert get(server, "/web/config") == {
            "tiles": "/api/v1/tiles/{z}/{x}/{y}",
            "local_tiles": True,
        }
        assert get(server, "/tiles")["center"] == [home[1], home[0], 18]
        page, console = open_page("fleet", server=server)
        answers: dict[tuple[int, int, int], int] = {}

        def seen(response) -> None:
            if match := re.search(r"/api/v1/tiles/(\d+)/(\d+)/(\d+)$", response.url):
                answers[tuple(int(v) for v in match.groups())] = response.status

        page.on("response", seen)
        page.reload()
        page.wait_for_selector("#page[data-mounted='fleet']")
        tiles = "#fleet-map .ground-tiles img.leaflet-tile-loaded"
        page.wait_for_function(f"document.querySelectorAll({tiles!r}).length >= 4", timeout=20_000)
        # Each image drawn is a tile of the file: its pixels are the colour written for it.
        drawn = page.evaluate(
            """(tiles) => [...document.querySelectorAll(tiles)].map((img) => {
                   const c = document.createElement('canvas');
                   c.width = img.naturalWidth; c.height = img.naturalHeight;
                   const g = c.getContext('2d');
                   g.drawImage(img, 0, 0);
                   return [img.naturalWidth, ...g.getImageData(128, 128, 1, 1).data.slice(0, 3)];
                 })""",
            tiles,
        )
        asked = {key for key, status in answers.items() if status == 200}
        assert asked and set(answers.values()) == {200}, answers  # none outside the file
        assert all(key in colours for key in asked)
        assert {z for z, _, _ in asked} <= {18}, asked  # at the file's deepest zoom, no deeper
        wanted = {colours[key] for key in asked}
        assert len(drawn) >= 4 and all(size == 256 for size, *_ in drawn)
        assert {tuple(rgb) for _, *rgb in drawn} <= wanted, (drawn, wanted)
        # Nothing left the machine; the grid is still underneath.
        assert {urlsplit(u).hostname for u in loaded_urls(page)} <= LOOPBACK
        assert page.locator("#fleet-map canvas.leaflet-tile").count() > 0
        assert page.locator("#fleet-map-no-tiles").count() == 0  # imagery: no note (issue 29)
        ARTIFACTS.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(ARTIFACTS / "map-mbtiles.png"))
        console.assert_clean()
    finally:
        server.stop()
