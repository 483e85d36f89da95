"""Telemetry from 3 simulated drones lands in SQLite and in a real InfluxDB (the seed's database),
and the query endpoint gives the same downsampled series from both.
"""

from __future__ import annotations

import asyncio
import time

import httpx
import pytest

from dronefleet.drone.config import DroneConfig
from dronefleet.geo.types import LLA
from dronefleet.ground.services import GroundServices
from dronefleet.sim.homes import homes_around
from dronefleet.simfleet import SimFleet
from support.brokers import mosquitto
from support.ground_procs import influxd

pytestmark = pytest.mark.integration


async def test_sqlite_and_influxdb_answer_the_same(tmp_path):
    with mosquitto(tmp_path) as broker, influxd(tmp_path) as influx_url:
        sqlite_ground = GroundServices(
            broker,
            store_url=f"sqlite:///{tmp_path}/t.db",
            state_path=tmp_path / "a.db",
            http_port=0,
        )
        influx_ground = GroundServices(  # a second ground: its own planner session
            broker,
            store_url=influx_url,
            state_path=tmp_path / "b.db",
            http_port=0,
            planner_client_id="ground-planner-influx",
        )
        async with sqlite_ground, influx_ground, SimFleet(speedup=5) as fleet:
            ids = ["TEL_A", "TEL_B", "TEL_C"]
            t0 = time.time()
            for drone_id, home in zip(ids, homes_around(LLA(40.63, -8.659, 10), 3), strict=True):
                await fleet.add_drone(DroneConfig(drone_id), broker, home=home)
            await asyncio.sleep(3.0)
            for app in list(fleet.apps.values()):
                await app.stop()
            fleet.apps.clear()
            t1 = time.time()
            await asyncio.sleep(1.0)  # both connectors flush
            assert sqlite_ground.connector.stored == influx_ground.connector.stored > 3 * 10
            answers = {}
            for name, ground in (("sqlite", sqlite_ground), ("influxdb", influx_ground)):
                headers = {"Authorization": f"Bearer {ground.operator_token}"}
                async with httpx.AsyncClient(base_url=ground.http_url, headers=headers) as api:
                    for drone_id in ids:
                        r = await api.get(
                            "/api/v1/telemetry",
                            params={
                                "drone": drone_id,
                                "from": t0 - 1,
                                "to": t1 + 1,
                                "every": "500ms",
                            },
                        )
                        assert r.status_code == 200, r.text
                        answers[name, drone_id] = r.json()
            for drone_id in ids:
                sq, ifx = answers["sqlite", drone_id], answers["influxdb", drone_id]
                assert sq["fields"], f"no telemetry stored for {drone_id}"
                assert sq == ifx
