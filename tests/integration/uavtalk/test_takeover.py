"""UAVTalk's flight mode changed by someone else pauses the mission; a resume finishes it
(issue 10).

A ``dronefleet drone --fc uavtalk`` process flies a mission on our simulated dRonin; the vehicle's
own hold (an RC pilot's flight-mode switch, seen by the drone in FlightStatus.FlightMode) takes it.
"""

from __future__ import annotations

import asyncio

import pytest

from dronefleet.drone.takeover import SOMEONE_ELSE
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.messaging.embedded import EmbeddedBroker
from dronefleet.sim.uavtalk import UAVTalkServer
from dronefleet.sim.world import SimWorld
from support.drones import Operator, drone_process, until_mid_leg

pytestmark = pytest.mark.integration

HOME = LLA(40.63, -8.659, 10.0)


def line(waypoints: int, spacing_m: float = 40.0) -> list[dict]:
    steps: list[dict] = [{"command": "arm"}, {"command": "takeoff", "value": 10}]
    for i in range(waypoints):
        wp = ned_to_lla(NED(spacing_m * (i + 1), 0), HOME)
        steps += [
            {"command": "navigate", "lat": wp.lat, "lon": wp.lon, "altitude_delta": 10},
            {"command": "wait_for_flight"},
        ]
    return [*steps, {"command": "land"}, {"command": "wait_for_flight"}]


async def test_a_flight_mode_set_by_someone_else_pauses_the_mission_over_uavtalk():
    steps = line(3)
    async with EmbeddedBroker(anonymous=True) as broker, SimWorld(speedup=20) as world:
        vehicle = world.add_vehicle("UAVT_K", HOME)
        async with UAVTalkServer(world) as server:
            url = server.endpoints["UAVT_K"]
            async with (
                drone_process(broker.url, "QUAD_UK", "--fc", "uavtalk", "--fc-url", url),
                Operator(broker.url) as op,
            ):

                def events(kind: str) -> list[dict]:
                    return [p for p in op.progress("uk") if p["event"] == kind]

                await op.send_mission("QUAD_UK", mission_id="uk", steps=steps)
                await op.wait_for(lambda: len(events("step")) >= 4, timeout_s=90)
                await until_mid_leg(vehicle)
                taken_at = world.clock.now()
                vehicle.hold()  # the pilot's switch: FlightStatus.FlightMode becomes HOLD
                (paused,) = await op.wait_for(lambda: events("paused"), timeout_s=20)
                assert paused["result"] == {"mode": "HOLD", "by": SOMEONE_ELSE}, paused
                assert -0.01 <= paused["vehicle_time_s"] - taken_at <= 1.0, (paused, taken_at)
                steps_then = len(events("step"))
                await asyncio.sleep(0.5)  # 10 vehicle seconds
                assert len(events("step")) == steps_then and vehicle.in_air
                await op.send_mission("QUAD_UK", mission_id="uk", action="resume")
                await op.wait_for(lambda: events("completed"), timeout_s=120)
                done = sorted({p["step_index"] for p in events("step")})
                assert done == list(range(len(steps))) and not events("failed")
