"""Issue 11, a ground that never answers 500: each request a reviewer found answered with a 500
is refused with a 4xx and its reason, and nothing is created.

One ground (its HTTP app driven in process) and ten simulated drones at 30 % battery serve the
whole module: the geometry refusals need one drone, the battery refusal all ten.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import AsyncIterator
from typing import Any

import httpx
import pytest
import pytest_asyncio

from dronefleet.drone.config import DroneConfig
from dronefleet.experiments.scenarios import rectangle
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.ground.services import GroundServices
from dronefleet.messaging.embedded import EmbeddedBroker
from dronefleet.simfleet import SimFleet

pytestmark = [pytest.mark.integration, pytest.mark.asyncio(loop_scope="module")]

HOME = LLA(40.63, -8.659, 10.0)
DRONES = [f"R{i}" for i in range(10)]
SQUARE = rectangle(0, 0, 100, 100)  # [lat, lon] corners, counter-clockwise from south-west


@pytest_asyncio.fixture(scope="module", loop_scope="module")
async def api(tmp_path_factory) -> AsyncIterator[httpx.AsyncClient]:
    tmp = tmp_path_factory.mktemp("refusals")
    async with EmbeddedBroker(anonymous=True) as broker:
        ground = GroundServices(
            broker.url,
            store_url="sqlite://:memory:",
            state_path=tmp / "ground.db",
            serve_http=False,
            planner_client_id="refusals-planner",
        )
        async with ground, SimFleet(speedup=10) as fleet:
            for i, drone_id in enumerate(DRONES):
                home = ned_to_lla(NED(0, 5 * i), HOME)
                await fleet.add_drone(
                    DroneConfig(drone_id=drone_id), broker.url, home=home, battery_pct=30.0
                )
            transport = httpx.ASGITransport(app=ground.app)
            headers = {"Authorization": f"Bearer {ground.operator_token}"}
            async with httpx.AsyncClient(
                transport=transport, base_url="http://ground", headers=headers, timeout=120
            ) as client:
                for _ in range(200):
                    known = {d["drone_id"] for d in (await client.get("/api/v1/drones")).json()}
                    if known >= set(DRONES):
                        break
                    await asyncio.sleep(0.1)
                yield client


def area(polygon: Any, **extra: Any) -> dict[str, Any]:
    return {"polygon": polygon, "spacing_m": 10, "altitude_m": 15, **extra}


def circle(n: int, radius_deg: float = 0.01) -> list[list[float]]:
    turns = [2 * math.pi * k / n for k in range(n)]
    return [
        [HOME.lat + radius_deg * math.sin(t), HOME.lon + radius_deg * math.cos(t)] for t in turns
    ]


def small_squares(count: int) -> list[list[list[float]]]:
    """``count`` holes of 4 vertices, ~10 m wide, in a grid near HOME."""
    return [
        [[HOME.lat + 3e-4 * (i // 10) + dy, HOME.lon + 4e-4 * (i % 10) + dx]
         for dy, dx in ((0, 0), (1e-4, 0), (1e-4, 1e-4), (0, 1e-4))]
        for i in range(count)
    ]  # fmt: skip


CAMERA = {
    "sensor_width_mm": 13.2,
    "sensor_height_mm": 8.8,
    "focal_length_mm": 8.8,
    "image_width_px": 5472,
    "image_height_px": 3648,
}

#: (what, the area, status, a part of the reason)
AREAS = [
    ("self-intersecting", area([SQUARE[0], SQUARE[2], SQUARE[1], SQUARE[3]]), 422, "not simple"),
    (
        "collinear (zero area)",
        area([[40.63, -8.659], [40.631, -8.659], [40.632, -8.659]]),  # on one meridian
        422,
        "not simple",
    ),
    ("repeated points", area([SQUARE[0], SQUARE[0], SQUARE[1], SQUARE[1]]), 422, "not simple"),
    ("hole outside", area(SQUARE, holes=[rectangle(500, 500, 10, 10)]), 422, "hole leaves it"),
    ("hole larger", area(SQUARE, holes=[rectangle(-50, -50, 300, 300)]), 422, "hole leaves it"),
    ("50 km square at 10 m", area(rectangle(0, 0, 50_000, 50_000)), 422, "at most 20000"),
    ("spacing 1e-300", area(SQUARE, spacing_m=1e-300), 422, "spacing_m: Input should be greater"),
    (
        "sensor width 1e-300",
        {"polygon": SQUARE, "camera": {**CAMERA, "sensor_width_mm": 1e-300}},
        422,
        "sensor_width_mm: Input should be greater",
    ),
    (
        "camera spacing below 0.5 m",
        {"polygon": SQUARE, "altitude_m": 1, "camera": {**CAMERA, "focal_length_mm": 1000}},
        422,
        "gives a line spacing of",
    ),
    (
        "polar triangle",
        area([[89.9, 0], [89.9, 120], [89.9, -120]]),
        422,
        "polygon.0.0: Input should be less than or equal to 85",
    ),
    (
        "2000 vertices and 100 holes",
        area(circle(2000), spacing_m=20, holes=small_squares(100)),
        422,
        "2400 vertices together; at most 2000",
    ),
]


@pytest.mark.parametrize(
    ("spec", "status", "reason"), [a[1:] for a in AREAS], ids=[a[0] for a in AREAS]
)
@pytest.mark.parametrize("path", ["/api/v1/missions/preview", "/api/v1/missions"])
async def test_an_area_that_cannot_be_planned_is_refused_with_the_reason(
    api, path, spec, status, reason
):
    r = await api.post(path, json={"drones": ["R0"], "area": spec})
    assert r.status_code == status, r.text
    assert reason in r.json()["detail"], r.text
    assert (await api.get("/api/v1/missions")).json() == []  # nothing was created


async def test_an_area_ten_drones_cannot_cover_on_their_batteries_is_refused(api):
    big = area(rectangle(0, 0, 1200, 1200))
    r = await api.post("/api/v1/missions/preview", json={"drones": DRONES, "area": big})
    assert r.status_code == 422, r.text
    assert "batteries cannot cover the route" in r.json()["detail"]


async def test_a_nul_in_a_web_path_is_not_found(api):
    r = await api.get("/web/%00index.html")
    assert r.status_code == 404 and "no web file" in r.json()["detail"]


async def test_a_start_index_past_64_bits_is_refused(api):
    body = {"steps": [{"command": "sleep", "value": 1}], "start_index": 2**64}
    r = await api.post("/api/v1/drones/R0/mission", json=body)
    assert r.status_code == 422, r.text
    assert "start_index: Input should be less than or equal to 10000" in r.json()["detail"]


async def test_an_audit_cursor_past_sqlite_integers_is_refused(api):
    r = await api.get("/api/v1/audit", params={"before_id": 2**63})
    assert r.status_code == 422, r.text
    assert "before_id: Input should be less than or equal to" in r.json()["detail"]


@pytest.mark.parametrize("path", ["/api/v1/drones/R1/commands/arm", "/control"])
async def test_a_timeout_shorter_than_any_answer_is_refused_before_sending(api, path):
    params = {"timeout_s": "5e-324"}
    if path == "/control":
        params |= {"command": "arm", "droneID": "R1"}
    r = await api.post(path, params=params)
    assert r.status_code == 422, r.text
    assert "timeout_s" in r.json()["detail"]
    sent = (await api.get("/api/v1/audit", params={"drone": "R1"})).json()
    assert all(entry["status"] != 200 for entry in sent)  # the drone was never asked


async def test_the_published_422_is_the_answered_422(api):
    """Every 422 is ``{"detail": "<text>", "errors": [...]}`` and the OpenAPI schema says so."""
    schema = (await api.get("/openapi.json")).json()
    preview = schema["paths"]["/api/v1/missions/preview"]["post"]["responses"]["422"]
    ref = preview["content"]["application/json"]["schema"]["$ref"].rsplit("/", 1)[1]
    body = schema["components"]["schemas"][ref]
    assert body["properties"]["detail"]["type"] == "string"
    assert body["properties"]["errors"]["type"] == "array"
    r = await api.post("/api/v1/missions/preview", json={"area": area(SQUARE, spacing_m=0)})
    assert r.status_code == 422 and isinstance(r.json()["detail"], str) and r.json()["errors"]
