"""A Will is input like any other message (issue 25): a drone's Will that the broker lets through
(on its own topics) but that is malformed, or speaks for another drone, is dropped and counted in
``GET /api/v1/health`` by the ground, never acted upon, and nothing dies. Against the embedded
default broker process, with the ground's services in this process.
"""

from __future__ import annotations

import asyncio
import json

import httpx
import pytest

from dronefleet.messaging.broker_users import BrokerRole
from dronefleet.messaging.embedded import EmbeddedBroker
from dronefleet.messaging.local_bus import Will
from support.fleet_brokers import NetworkProbe
from support.ground_api import local_ground

pytestmark = pytest.mark.integration


async def test_malformed_and_forged_wills_are_dropped_and_counted(tmp_path):
    async with EmbeddedBroker() as broker:
        ground_url = broker.url_for("ground", BrokerRole.GROUND)
        a_url = broker.url_for("QUAD_1", BrokerRole.DRONE)
        login = (a_url.username or "", a_url.password or "")
        ground = local_ground(ground_url, tmp_path, "will-test-planner")
        async with ground:
            auth = {"Authorization": f"Bearer {ground.operator_token}"}
            async with httpx.AsyncClient(base_url=ground.http_url, headers=auth) as api:

                async def dropped() -> int:
                    health = (await api.get("/api/v1/health")).json()
                    return sum(health["dropped_messages"].values())

                before = await dropped()
                other = {
                    "drone_id": "QUAD_2", "level": "CRITICAL", "message": "battery 3 %",
                    "position": {"lat": 40.63, "lon": -8.66, "alt": 20.0},
                    "vehicle_time_s": 1.0,
                }  # fmt: skip
                wills = [
                    Will("QUAD_1/alarms/out", b"\xff\xfe not json", 1),
                    Will("QUAD_1/alarms/out", json.dumps(other).encode(), 1),
                    Will("QUAD_1/heartbeats/out", b'{"drone_id": "QUAD_1", "interval_s": 1e300}'),
                ]
                for n, will in enumerate(wills):
                    probe = await NetworkProbe(broker.url).open(
                        f"QUAD_1-will{n}", login, clean=True, will=will
                    )
                    assert not probe.refused
                    await probe.drop()
                for _ in range(100):
                    if await dropped() - before >= len(wills):
                        break
                    await asyncio.sleep(0.1)
                assert await dropped() - before == len(wills)
                assert (await api.get("/api/v1/drones")).json() == []  # no phantom believed
                alarms = await api.get("/api/v1/health")
                assert alarms.status_code in (200, 503)  # the ground still answers


async def test_a_stolen_drones_will_does_not_move_a_real_drone(tmp_path):
    """The drone side of QUAD_2 on a simulated vehicle, on the embedded broker: QUAD_1's Wills
    (arm, take off, plain and retained) on QUAD_2's command topics are never obeyed; the ground's
    own arm is (the control)."""
    from dronefleet.drone.config import DroneConfig
    from dronefleet.geo.types import LLA
    from dronefleet.messaging.client import BrokerClient
    from dronefleet.simfleet import SimFleet

    async with EmbeddedBroker() as broker, SimFleet(speedup=5) as fleet:
        b_url = broker.url_for("QUAD_2", BrokerRole.DRONE)
        a_url = broker.url_for("QUAD_1", BrokerRole.DRONE)
        ground_url = broker.url_for("ground", BrokerRole.GROUND)
        await fleet.add_drone(DroneConfig("QUAD_2"), b_url, home=LLA(40.63, -8.659, 10.0))
        vehicle = fleet.world.vehicles["QUAD_2"]
        await asyncio.sleep(1.0)
        login = (a_url.username or "", a_url.password or "")
        arm = json.dumps({"request_id": "a" * 32, "command": "arm"}).encode()
        takeoff = json.dumps({"request_id": "b" * 32, "command": "takeoff", "altitude": 15})
        for n, (payload, retain) in enumerate(
            [(arm, False), (takeoff.encode(), False), (arm, True), (takeoff.encode(), True)]
        ):
            probe = await NetworkProbe(broker.url).open(
                f"QUAD_1-w{n}",
                login,
                clean=True,
                will=Will("QUAD_2/control/in", payload, 1, retain),
            )
            await probe.drop()
        await asyncio.sleep(3.0)
        assert not vehicle.armed and not vehicle.arming and not vehicle.in_air
        async with BrokerClient(ground_url, "ground-manager") as ground:
            await ground.publish("QUAD_2/control/in", arm)
            for _ in range(100):  # the control: the ground's own arm is obeyed (3 s to arm)
                if vehicle.armed or vehicle.arming:
                    break
                await asyncio.sleep(0.1)
        assert vehicle.armed or vehicle.arming
