"""Maps in the field (issue 14): tiles from a local MBTiles file, and the maps' search box.

A ground started with ``tiles=`` an MBTiles file the test builds serves its tiles to whoever
the Drone Manager accepts, and nobody else; ``/api/v1/search`` reads coordinates, drones,
missions and, through a Nominatim-compatible geocoder (a small HTTP server of the test's own,
answering Nominatim's JSON), addresses.
"""

from __future__ import annotations

import io
import time

import httpx
import pytest
from PIL import Image

from dronefleet.ground.manager.auth import Role
from dronefleet.ground.manager.mbtiles import MBTilesError
from dronefleet.ground.services import GroundServices
from support.ground_fakes import FakeDrone, eventually
from support.mbtiles import build, tile_of
from support.nominatim import Nominatim

pytestmark = pytest.mark.integration
FIELD = (40.63, -8.659)


@pytest.fixture
def geocoder():
    server = Nominatim()
    yield server
    server.close()


async def a_ground(broker, tmp_path, **options) -> GroundServices:
    ground = GroundServices(
        broker,
        store_url=f"sqlite:///{tmp_path}/t.db",
        state_path=tmp_path / "g.db",
        http_port=0,
        command_timeout_s=2,
        planner_client_id=f"maps-{time.monotonic_ns()}",
        **options,
    )
    return await ground.start()


def client(ground: GroundServices, token: str | None) -> httpx.AsyncClient:
    headers = {"Authorization": f"Bearer {token}"} if token else {}
    return httpx.AsyncClient(base_url=ground.http_url, headers=headers, timeout=10)


async def test_tiles_from_an_mbtiles_file_are_served_to_the_signed_in_only(
    embedded_broker, tmp_path
):
    colours = build(tmp_path / "field.mbtiles", FIELD, range(15, 18))
    ground = await a_ground(embedded_broker, tmp_path, tiles=tmp_path / "field.mbtiles")
    try:
        viewer = await ground.app.state.ctx.tokens.issue("v", Role.VIEWER)
        async with client(ground, viewer) as api, client(ground, None) as stranger:
            config = (await stranger.get("/api/v1/web/config")).json()
            assert config == {"tiles": "/api/v1/tiles/{z}/{x}/{y}", "local_tiles": True}
            meta = (await api.get("/api/v1/tiles")).json()
            assert meta["name"] == "test field" and meta["format"] == "png"
            assert (meta["min_zoom"], meta["max_zoom"], meta["tiles"]) == (15, 17, 27)
            assert meta["center"] == [FIELD[1], FIELD[0], 17]
            for (z, x, y), rgb in colours.items():
                r = await api.get(f"/api/v1/tiles/{z}/{x}/{y}")
                assert r.status_code == 200 and r.headers["content-type"] == "image/png"
                assert r.headers["cache-control"] == "private, max-age=3600"
                with Image.open(io.BytesIO(r.content)) as im:
                    assert im.size == (256, 256) and im.convert("RGB").getpixel((9, 9)) == rgb
            x, y = tile_of(*FIELD, 17)
            missing = await api.get(f"/api/v1/tiles/17/{x + 9}/{y}")
            assert missing.status_code == 404 and "no tile" in missing.json()["detail"]
            assert (await api.get(f"/api/v1/tiles/31/{x}/{y}")).status_code == 422
            assert (await api.get("/api/v1/tiles/17/-1/0")).status_code == 422
            # No credentials, or unknown ones: no imagery.
            refused = await stranger.get(f"/api/v1/tiles/17/{x}/{y}")
            assert refused.status_code == 401 and "token" in refused.json()["detail"]
            assert (await stranger.get("/api/v1/tiles")).status_code == 401
            stranger.headers["Authorization"] = "Bearer not-a-token"
            assert (await stranger.get(f"/api/v1/tiles/17/{x}/{y}")).status_code == 401
    finally:
        await ground.stop()


async def test_without_tiles_the_config_says_none_and_a_bad_file_stops_the_start(
    embedded_broker, tmp_path
):
    ground = await a_ground(embedded_broker, tmp_path)
    try:
        async with client(ground, ground.operator_token) as api:
            assert (await api.get("/api/v1/web/config")).json() == {
                "tiles": None, "local_tiles": False
            }  # fmt: skip
            none = await api.get("/api/v1/tiles/1/0/0")
            assert none.status_code == 404 and "--tiles" in none.json()["detail"]
    finally:
        await ground.stop()
    (tmp_path / "junk.mbtiles").write_bytes(b"junk" * 1000)
    with pytest.raises(MBTilesError, match="not an MBTiles file"):
        await a_ground(embedded_broker, tmp_path, tiles=tmp_path / "junk.mbtiles")


async def test_search_reads_coordinates_drones_missions_and_addresses(
    embedded_broker, tmp_path, geocoder
):
    ground = await a_ground(embedded_broker, tmp_path, geocoder=geocoder.url)
    drone = await FakeDrone(embedded_broker, "QUAD_7").start()
    try:
        async with client(ground, ground.operator_token) as api:

            async def search(q: str) -> httpx.Response:
                return await api.get("/api/v1/search", params={"q": q})

            dms = (await search("40°37'48\"N 8°39'36\"W")).json()
            assert dms["places"] == [
                {"kind": "coordinates", "label": "40.630000, -8.660000", "lat": 40.63,
                 "lon": -8.66, "bounds": None}
            ]  # fmt: skip
            assert (await search("40.63, -8.66")).json()["places"][0]["lat"] == 40.63
            bad = await search("91, 0")
            assert bad.status_code == 422 and "latitude 91" in bad.json()["detail"]
            assert not geocoder.asked  # coordinates never leave the ground

            await eventually(lambda: api.get("/api/v1/drones/QUAD_7"), timeout_s=10)
            found = (await search("quad_7")).json()["places"]
            assert [p["kind"] for p in found] == ["drone"]
            assert (found[0]["label"], found[0]["lat"], found[0]["lon"]) == (
                "drone QUAD_7",
                40.63,
                -8.659,
            )

            steps = [
                {"command": "navigate", "lat": lat, "lon": lon, "altitude_delta": 10}
                for lat, lon in ((40.6310, -8.6600), (40.6330, -8.6570))
            ]
            made = await api.post(
                "/api/v1/missions",
                json={"name": "North field", "drones": ["QUAD_7"], "steps": steps},
            )
            assert made.status_code == 201, made.text
            mission = (await search("north FIELD")).json()["places"]
            assert [p["kind"] for p in mission] == ["mission"]
            assert mission[0]["bounds"] == [40.631, -8.66, 40.633, -8.657]
            assert mission[0]["label"] == f"mission North field ({made.json()['mission_id']})"

            address = (await search("Rua de Aveiro 10")).json()
            assert address["places"] == [
                {"kind": "address", "label": "Rua de Aveiro 10, Aveiro, Portugal",
                 "lat": 40.6405, "lon": -8.6538, "bounds": [40.64, -8.65455, 40.641, -8.65305]}
            ]  # fmt: skip
            again = await search("Rua de Aveiro 11")
            assert again.status_code == 200
            await search("rua de  AVEIRO 10")  # the same query: answered from the cache
            assert len(geocoder.asked) == 2
            (t1, query, agent), (t2, _, _) = geocoder.asked
            assert query == {"q": ["Rua de Aveiro 10"], "format": ["jsonv2"], "limit": ["5"]}
            assert agent.startswith("dronefleet/")
            assert t2 - t1 >= 0.95  # Nominatim's policy: one request a second at most
            viewer = await ground.app.state.ctx.tokens.issue("v", Role.VIEWER)
            async with client(ground, viewer) as view, client(ground, None) as stranger:
                assert (await view.get("/api/v1/search", params={"q": "QUAD_7"})).status_code == 200
                assert (await stranger.get("/api/v1/search", params={"q": "x"})).status_code == 401
            assert (await api.get("/api/v1/search", params={"q": ""})).status_code == 422
    finally:
        await drone.stop()
        await ground.stop()


async def test_addresses_without_a_geocoder_or_with_a_broken_one_say_why(embedded_broker, tmp_path):
    ground = await a_ground(embedded_broker, tmp_path)
    try:
        async with client(ground, ground.operator_token) as api:
            answer = (await api.get("/api/v1/search", params={"q": "Aveiro"})).json()
            assert answer["places"] == [] and "--geocoder" in answer["note"]
    finally:
        await ground.stop()
    broken = Nominatim(status=500)
    (tmp_path / "2").mkdir()
    ground = await a_ground(embedded_broker, tmp_path / "2", geocoder=broken.url)
    try:
        async with client(ground, ground.operator_token) as api:
            r = await api.get("/api/v1/search", params={"q": "Aveiro"})
            assert r.status_code == 503 and "geocoder answered HTTP 500" in r.json()["detail"]
    finally:
        await ground.stop()
        broken.close()
