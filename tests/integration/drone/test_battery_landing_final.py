"""A drone's own battery landing is final (issue 26, item 3), in one process on virtual time.

Measured on SITL before: a drone whose battery read 0 % decided to land where it was, then the
return-home leg the ground had queued for it arrived and took it back up towards home. Now, once
it lands for its battery, a return order (a direct ``rtl``, a mission that flies home) is
refused with the reason until it is down, and it lands where it decided to.
"""

from __future__ import annotations

import pytest

from dronefleet.drone.config import DroneConfig
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.messaging.broker_users import BrokerRole
from dronefleet.messaging.local_bus import LocalBus
from dronefleet.simfleet import SimFleet
from support.drones import Operator

pytestmark = [pytest.mark.integration, pytest.mark.virtual_time]
HOME = LLA(40.63, -8.659, 10.0)


def far_and_back(legs: int, length_m: float = 150.0) -> list[dict]:
    steps: list[dict] = [{"command": "arm"}, {"command": "takeoff", "value": 10}]
    for i in range(legs):
        wp = ned_to_lla(NED(length_m * (1 + i % 2), 0), HOME)
        steps += [
            {"command": "navigate", "lat": wp.lat, "lon": wp.lon, "altitude_delta": 10},
            {"command": "wait_for_flight"},
        ]
    return steps


def events(op: Operator, mission_id: str, kind: str) -> list[dict]:
    return [p for p in op.progress(mission_id) if p["event"] == kind]


async def test_a_return_order_after_the_drones_own_battery_landing_is_refused():
    bus = await LocalBus().start()
    config = DroneConfig(drone_id="BAT_F", battery_rtl_pct=6.5, battery_land_pct=6.5)
    async with (
        SimFleet() as fleet,
        Operator(bus.url_for("operator", BrokerRole.GROUND)) as op,
    ):
        await fleet.add_drone(
            config, bus.url_for("BAT_F", BrokerRole.DRONE), home=HOME, battery_pct=7.4
        )
        vehicle = fleet.world.vehicles["BAT_F"]
        await op.send_mission("BAT_F", mission_id="far", steps=far_and_back(20))
        (stop,) = await op.wait_for(lambda: events(op, "far", "stopped"), timeout_s=300)
        assert "landing here" in stop["error"], stop
        assert vehicle.in_air
        landing_at = vehicle.position_ned

        refused = await op.command("BAT_F", command="rtl")  # the ground's order, later
        assert not refused["ok"], refused
        assert "return home refused: the drone is landing for its battery" in refused["error"]

        home_leg = [{"command": "rtl"}, {"command": "wait_for_flight"}]  # a recovery leg
        await op.send_mission("BAT_F", mission_id="home", steps=home_leg)
        (failed,) = await op.wait_for(lambda: events(op, "home", "failed"), timeout_s=60)
        assert "landing for its battery" in failed["error"], failed

        while vehicle.in_air or vehicle.armed:
            await fleet.clock.sleep(0.5)
        assert (
            vehicle.position_ned - landing_at
        ).horizontal_m < 25.0  # there (braking from 10 m/s)
        assert vehicle.position_ned.horizontal_m > 50.0  # not home

        answer = await op.command("BAT_F", command="arm")  # down: it obeys again
        assert answer["ok"], answer
    await bus.stop()
