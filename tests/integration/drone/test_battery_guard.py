"""Battery fail-safe levels on the drone (issue 14): below 12 % it comes home, below 6 % it lands.

No ground answers the CRITICAL alarm here (no planner: the mission is sent to the drone itself),
so the drone acts on its own, as ArduPilot's BATT_FS_LOW_ACT / BATT_FS_CRT_ACT do.
"""

from __future__ import annotations

import pytest

from dronefleet.drone.config import DroneConfig
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.simfleet import SimFleet
from support.drones import Operator

pytestmark = pytest.mark.integration
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


def stopped(op: Operator, mission_id: str) -> list[dict]:
    return [p for p in op.progress(mission_id) if p["event"] == "stopped"]


async def test_below_the_rtl_level_the_drone_stops_its_mission_and_comes_home(embedded_broker):
    async with SimFleet(speedup=50) as fleet, Operator(embedded_broker) as op:
        await fleet.add_drone(DroneConfig(drone_id="BAT_R"), embedded_broker, home=HOME,
                              battery_pct=15.0)  # fmt: skip
        vehicle = fleet.world.vehicles["BAT_R"]
        await op.send_mission("BAT_R", mission_id="b1", steps=far_and_back(40))
        (stop,) = await op.wait_for(lambda: stopped(op, "b1"), timeout_s=120)
        assert "battery at" in stop["error"] and "returning home" in stop["error"], stop
        while vehicle.in_air or vehicle.armed:
            await fleet.clock.sleep(1.0)
        assert vehicle.position_ned.horizontal_m < 3.0  # at home
        assert vehicle.battery_state.remaining_pct > 5.0  # before the autopilot's own failsafe
        assert not [p for p in op.progress("b1") if p["event"] == "completed"]


async def test_below_the_land_level_the_drone_lands_where_it_is(embedded_broker):
    async with SimFleet(speedup=50) as fleet, Operator(embedded_broker) as op:
        config = DroneConfig(drone_id="BAT_L", battery_rtl_pct=7.0, battery_land_pct=6.5)
        await fleet.add_drone(config, embedded_broker, home=HOME, battery_pct=9.0)
        vehicle = fleet.world.vehicles["BAT_L"]
        await op.send_mission("BAT_L", mission_id="b2", steps=far_and_back(40))
        await op.wait_for(lambda: stopped(op, "b2"), timeout_s=120)  # the RTL level first
        while vehicle.in_air or vehicle.armed:
            await fleet.clock.sleep(1.0)
        reasons = [p["error"] for p in stopped(op, "b2")]
        assert "returning home" in reasons[0], reasons
        assert vehicle.position_ned.horizontal_m > 20.0  # it came down on its way, not home
        assert vehicle.battery_state.remaining_pct > 5.0
