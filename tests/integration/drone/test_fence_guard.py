"""The geofence kept to in flight (issue 14): out of the fence, the drone stops and comes home.

A mission sent to the drone by hand (the ground would have refused it) flies past its fence's
inclusion polygon; the drone notices within its margin, stops the mission with the reason and
returns home. The same mission with a fence that holds it flies to the end.
"""

from __future__ import annotations

import pytest

from dronefleet.drone.config import DroneConfig
from dronefleet.drone.fence_guard import MARGIN_M
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.simfleet import SimFleet
from support.drones import Operator

pytestmark = pytest.mark.integration
HOME = LLA(40.63, -8.659, 10.0)


def box(n0: float, e0: float, n1: float, e1: float) -> list[list[float]]:
    corners = [(n0, e0), (n0, e1), (n1, e1), (n1, e0)]
    return [[p.lat, p.lon] for p in (ned_to_lla(NED(n, e), HOME) for n, e in corners)]


def north(*metres: float) -> list[dict]:
    steps: list[dict] = [{"command": "arm"}, {"command": "takeoff", "value": 10}]
    for m in metres:
        wp = ned_to_lla(NED(m, 0), HOME)
        steps += [
            {"command": "navigate", "lat": wp.lat, "lon": wp.lon, "altitude_delta": 10},
            {"command": "wait_for_flight"},
        ]
    return [*steps, {"command": "land"}, {"command": "wait_for_flight"}]


def events(op: Operator, mission_id: str, kind: str) -> list[dict]:
    return [p for p in op.progress(mission_id) if p["event"] == kind]


async def test_a_drone_leaving_its_fence_stops_and_comes_home(embedded_broker):
    async with SimFleet(speedup=20) as fleet, Operator(embedded_broker) as op:
        await fleet.add_drone(DroneConfig(drone_id="FENCE_1"), embedded_broker, home=HOME)
        vehicle = fleet.world.vehicles["FENCE_1"]
        fence = {"inclusion": box(-20, -20, 60, 20)}
        await op.send_mission("FENCE_1", mission_id="f1", steps=north(40, 100), fence=fence)
        (stop,) = await op.wait_for(lambda: events(op, "f1", "stopped"), timeout_s=60)
        assert "fence breach: outside the inclusion fence" in stop["error"], stop
        where = ned_to_lla(NED(0, 0), HOME)
        breach_n = (stop["position"]["lat"] - where.lat) * 111_320
        assert 60 < breach_n < 60 + MARGIN_M + 3, breach_n  # caught at the line, not far past
        while vehicle.in_air or vehicle.armed:
            await fleet.clock.sleep(1.0)
        assert vehicle.position_ned.horizontal_m < 3.0  # home
        assert not events(op, "f1", "completed")


async def test_a_mission_inside_its_fence_flies_to_the_end(embedded_broker):
    async with SimFleet(speedup=20) as fleet, Operator(embedded_broker) as op:
        await fleet.add_drone(DroneConfig(drone_id="FENCE_2"), embedded_broker, home=HOME)
        fence = {"inclusion": box(-20, -20, 60, 20), "ceiling_m": 30}
        await op.send_mission("FENCE_2", mission_id="f2", steps=north(40, 55), fence=fence)
        await op.wait_for(lambda: events(op, "f2", "completed"), timeout_s=60)
        assert not events(op, "f2", "stopped")
