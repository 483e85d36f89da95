"""A drone process on a UAVTalk autopilot: MQTT commands reach the simulated dRonin.

``dronefleet drone --fc uavtalk --fc-url tcp:...`` in its own process, our UAVTalk simulator in
the test's process, an embedded broker between the drone and the operator — the seed's chain
(ground -> broker -> Drone Controller -> Flight Controller Interface -> UAVTalk -> autopilot).
"""

from __future__ import annotations

import asyncio

import pytest

from dronefleet.geo.types import LLA
from dronefleet.messaging.embedded import EmbeddedBroker
from dronefleet.sim.uavtalk import UAVTalkServer
from dronefleet.sim.world import SimWorld
from support.drones import Operator, drone_process

pytestmark = pytest.mark.integration

HOME = LLA(40.63, -8.659, 10.0)


async def test_mqtt_arm_and_takeoff_reach_the_vehicle_over_uavtalk():
    async with (
        EmbeddedBroker(anonymous=True) as broker,
        SimWorld(speedup=20) as world,
    ):
        vehicle = world.add_vehicle("UAVT_1", HOME)
        async with UAVTalkServer(world) as server:
            url = server.endpoints["UAVT_1"]
            async with (
                drone_process(broker.url, "QUAD_UAVT", "--fc", "uavtalk", "--fc-url", url),
                Operator(broker.url) as op,
            ):
                beat = await op.heartbeat("QUAD_UAVT")
                assert beat["drone_id"] == "QUAD_UAVT"
                # GPSPosition's Status and Satellites; dRonin estimates no wind: none is sent.
                assert beat["gps"]["fix"] == "3d" and beat["gps"]["satellites"] == 12, beat
                assert "wind" not in beat

                armed = await op.command("QUAD_UAVT", command="arm")
                assert armed["ok"], armed
                # 3 s of arming, measured on the autopilot's clock (SystemStats), not the wall.
                assert armed["result"]["arming_time_s"] == pytest.approx(3.0, abs=0.4)
                assert vehicle.armed

                on_ground = await op.command("QUAD_UAVT", command="disarm")
                assert on_ground["ok"] and not vehicle.armed  # on the ground a disarm is fine
                assert (await op.command("QUAD_UAVT", command="arm"))["ok"]

                took_off = await op.command("QUAD_UAVT", command="takeoff", value=10)
                assert took_off["ok"], took_off
                loop = asyncio.get_running_loop()
                deadline = loop.time() + 20
                while vehicle.relative_alt_m < 9.5:
                    assert loop.time() < deadline, f"vehicle stuck at {vehicle.relative_alt_m} m"
                    await asyncio.sleep(0.1)

                answer = await op.command("QUAD_UAVT", command="objrequest", value="GPSPosition")
                assert answer["ok"], answer
                assert answer["result"]["data"]["Altitude"] == pytest.approx(20.0, abs=0.6)

                no = await op.command("QUAD_UAVT", command="disarm")
                assert not no["ok"] and "in flight" in no["error"]
