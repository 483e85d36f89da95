"""The ground believes a drone's message only from that drone (issue 12, must-show 3).

A drone with credentials of its own (SPARE) — or anyone who reaches the broker — forges a
CRITICAL alarm about the drone flying a mission (FULL), a phantom drone announces itself with an
absurd heartbeat interval, and a drone id that is an HTML payload announces itself. Each is
dropped and counted (``GET /api/v1/health``: ``dropped_messages``); no replacement starts, the
mission completes with FULL alone, and neither phantom is ever in the fleet (while the same
heartbeat with a sane interval and id is).
"""

from __future__ import annotations

import asyncio

import httpx
import orjson
import pytest

from dronefleet.drone.config import DroneConfig
from dronefleet.experiments.scenarios import rectangle
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.messaging.client import BrokerClient
from dronefleet.simfleet import SimFleet
from support.ground_api import local_ground

pytestmark = pytest.mark.integration
HOME = LLA(40.63, -8.659, 10.0)
WHERE = {"lat": HOME.lat, "lon": HOME.lon, "alt_m": HOME.alt_m + 15}


def beat(drone_id: str, **extra) -> dict:
    return {
        "drone_id": drone_id, "vehicle_time_s": 1.0, "position": WHERE,
        "battery": {"remaining_pct": 90.0, "voltage_v": 16.0}, "state": "flying", "mode": "GUIDED",
        **extra,
    }  # fmt: skip


async def _until(predicate, timeout_s: float = 60.0):
    async with asyncio.timeout(timeout_s):
        while not (found := await predicate()):
            await asyncio.sleep(0.2)
    return found


async def test_forged_alarms_and_phantom_drones_are_dropped_counted_and_never_acted_on(
    embedded_broker, tmp_path
):
    async with SimFleet(speedup=10) as fleet:
        await fleet.add_drone(DroneConfig(drone_id="FULL"), embedded_broker, home=HOME)
        spare_home = ned_to_lla(NED(0, 20), HOME)
        await fleet.add_drone(DroneConfig(drone_id="SPARE"), embedded_broker, home=spare_home)
        ground = local_ground(embedded_broker, tmp_path, "forged-test-planner")
        async with ground:
            auth = {"Authorization": f"Bearer {ground.operator_token}"}
            async with (
                httpx.AsyncClient(base_url=ground.http_url, headers=auth, timeout=30) as api,
                BrokerClient(embedded_broker, "forger") as forger,
            ):

                async def both_online():
                    seen = {d["drone_id"] for d in (await api.get("/api/v1/drones")).json()}
                    return seen >= {"FULL", "SPARE"}

                await _until(both_online)
                area = {"polygon": rectangle(20, 0, 30, 40), "spacing_m": 10, "altitude_m": 15}
                made = await api.post("/api/v1/missions", json={"drones": ["FULL"], "area": area})
                assert made.status_code == 201, made.text
                mission = made.json()["mission_id"]
                assert (await api.post(f"/api/v1/missions/{mission}/start")).status_code == 200
                detail = (await api.get(f"/api/v1/missions/{mission}")).json()
                leg = detail["legs"][0]["leg_id"]

                critical = {
                    "drone_id": "FULL", "level": "CRITICAL", "message": "battery 3 %",
                    "position": WHERE, "mission_id": leg, "vehicle_time_s": 5.0,
                }  # fmt: skip
                for topic in ("SPARE/alarms/out", "EVIL/alarms/out"):
                    await forger.publish(topic, orjson.dumps(critical), qos=1)
                await forger.publish("PHANTOM_1/heartbeats/out", orjson.dumps(
                    beat("PHANTOM_1", interval_s=1e300)))  # fmt: skip
                # An HTML payload as a drone id, on a topic a broker takes (NATS refuses a topic
                # with spaces outright: its client is cut off, so the payload rides on a valid one).
                html = '<img src=x onerror="alert(1)">'
                await forger.publish("HTML_1/heartbeats/out", orjson.dumps(beat(html)))
                # The control: the same heartbeat with a sane interval and id is believed.
                await forger.publish("GOOD_1/heartbeats/out", orjson.dumps(beat("GOOD_1")))

                async def counted():
                    dropped = (await api.get("/api/v1/health")).json()["dropped_messages"]
                    return dropped if dropped.get("alarm", 0) >= 2 else None

                dropped = await _until(counted, 20)
                assert dropped.get("malformed heartbeat", 0) >= 2, dropped

                async def ended():
                    body = (await api.get(f"/api/v1/missions/{mission}")).json()
                    return body if body["state"] in ("completed", "failed", "stalled") else None

                final = await _until(ended, 240)
                fleet_ids = {d["drone_id"] for d in (await api.get("/api/v1/drones")).json()}
    assert final["state"] == "completed", final.get("error")
    assert final["handovers"] == [] and final["alarms"] == []
    assert {leg["drone_id"] for leg in final["legs"]} == {"FULL"}  # SPARE never launched
    assert fleet_ids == {"FULL", "SPARE", "GOOD_1"}
