"""What the drones measured is kept and exported (issue 14): a gas plume on the map.

A drone surveys an area over a simulated CO2 plume, reading its sensor at every waypoint. The
mission keeps every reading with its step; ``GET /missions/{id}/readings`` gives them as GeoJSON
and CSV, and the highest reading lies at the plume.
"""

from __future__ import annotations

import asyncio
import csv
import io

import httpx
import pytest

from dronefleet.drone.config import DroneConfig
from dronefleet.experiments.scenarios import rectangle
from dronefleet.geo.ned import lla_to_ned, ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.ground.planner.measurements import COLUMNS
from dronefleet.simfleet import SimFleet
from support.ground_api import flown, local_ground

pytestmark = pytest.mark.integration
HOME = LLA(40.63, -8.659, 10.0)
PLUME = ned_to_lla(NED(30, 15), HOME)


async def test_readings_over_a_plume_are_kept_and_exported(embedded_broker, tmp_path):
    ground = local_ground(embedded_broker, tmp_path, "measure-planner")
    plume = (PLUME.lat, PLUME.lon, 20000.0, 15.0)  # centred at sea level: 25 m below
    async with ground, SimFleet(speedup=20, plumes=[plume]) as fleet:
        # No OUT_MEASURE alarm here: the plume is mapped, not chased.
        quiet = {"co2_ppm": (None, 1e9)}
        config = DroneConfig(drone_id="GAS", sensor_bounds=quiet)
        await fleet.add_drone(config, embedded_broker, home=HOME)
        headers = {"Authorization": f"Bearer {ground.operator_token}"}
        # 30 s: the first plan starts the planning worker process, slow on a loaded machine.
        async with httpx.AsyncClient(base_url=ground.http_url, headers=headers, timeout=30) as api:
            for _ in range(100):
                if (await api.get("/api/v1/drones/GAS")).status_code == 200:
                    break
                await asyncio.sleep(0.1)
            area = {"polygon": rectangle(10, 0, 40, 30), "spacing_m": 10, "altitude_m": 15,
                    "action": "read_sensors", "hold_s": 1}  # fmt: skip
            spec = {"drones": ["GAS"], "area": area, "options": {"collaboration": False}}
            detail = await flown(api, spec, timeout_s=60)
            assert detail["state"] == "completed", detail["error"]
            mission_id = detail["mission_id"]
            geo = await api.get(f"/api/v1/missions/{mission_id}/readings")
            table = await api.get(f"/api/v1/missions/{mission_id}/readings?format=csv")
            log = (await api.get(f"/api/v1/missions/{mission_id}/log")).json()
            bad = await api.get(f"/api/v1/missions/{mission_id}/readings?format=kml")
            missing = await api.get("/api/v1/missions/nope/readings")

    reads = sum(1 for step in detail["work"] if step["command"] == "read_sensors")
    assert geo.status_code == 200 and geo.headers["content-type"] == "application/geo+json"
    features = geo.json()["features"]
    assert len(features) == reads >= 12
    values = [f["properties"]["value"] for f in features]
    top = max(features, key=lambda f: f["properties"]["value"])
    lon, lat, _alt = top["geometry"]["coordinates"]
    assert lla_to_ned(LLA(lat, lon, HOME.alt_m), PLUME).horizontal_m < 12.0  # at the plume
    assert max(values) > 3 * min(values)  # the plume stands out of the background
    rows = list(csv.DictReader(io.StringIO(table.text)))
    assert table.headers["content-type"].startswith("text/csv")
    assert tuple(rows[0].keys()) == COLUMNS and len(rows) == reads
    assert {r["sensor"] for r in rows} == {"CO2"} and {r["unit"] for r in rows} == {"ppm"}
    logged = [s for d in log["drones"] for s in d["steps"] if "measured" in s]
    assert len(logged) == reads
    assert bad.status_code == 422 and missing.status_code == 404
