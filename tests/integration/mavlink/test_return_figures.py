"""The drone reports how its autopilot flies home (issue 28, item 3): RTL_ALT, RTL_SPEED,
RTL_ALT_FINAL, RTL_LOIT_TIME, RTL_CONE_SLOPE, RTL_CLIMB_MIN and LAND_SPEED_HIGH read at connect
go into ``Heartbeat.flight`` (validated; a zero that is a setting kept), and the planner's
estimate of the way home uses them instead of ArduPilot's defaults.
"""

from __future__ import annotations

import pytest

from dronefleet.drone.fc.mavlink import open_flight_controller
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import NED
from dronefleet.ground.planner.estimate import VehicleModel, estimate
from dronefleet.messaging.status import FlightParams

from .conftest import HOME

pytestmark = pytest.mark.integration


def url(endpoint) -> str:
    return f"udpout:127.0.0.1:{endpoint.port}"


async def reported(server, **params: float) -> dict:
    endpoint = server.endpoints[0]
    for name, value in params.items():
        endpoint.copter.params.set(name, value)
    fc = await open_flight_controller(url(endpoint), set_link_failsafe=False)
    try:
        return FlightParams(**fc.flight_params()).model_dump(exclude_none=True)
    finally:
        await fc.close()


def way_home_s(flight: dict) -> float:
    """An RTL from a hover 200 m out at 10 m, by the vehicle's own figures."""
    far = ned_to_lla(NED(200, 0, -10), HOME)
    est = estimate([{"command": "rtl"}], far, HOME, airborne=True,
                   model=VehicleModel.of_vehicle(flight))  # fmt: skip
    return est.duration_s


async def test_the_autopilots_return_figures_are_reported_and_estimated(sim_fleet):
    async with sim_fleet(1) as server:
        defaults = await reported(server)
    assert defaults["rtl_alt_m"] == 15.0
    assert defaults["rtl_loiter_s"] == 5.0
    assert defaults["rtl_cone_slope"] == 3.0
    assert defaults["rtl_alt_final_m"] == 0.0  # zero is a setting: land at the end
    assert defaults["rtl_climb_min_m"] == 0.0
    assert "rtl_speed_mps" not in defaults  # RTL_SPEED 0: it flies home at WPNAV_SPEED

    async with sim_fleet(1) as server:
        own = await reported(server, RTL_ALT=4000, RTL_SPEED=300, RTL_LOIT_TIME=0)
    assert own["rtl_alt_m"] == 40.0 and own["rtl_speed_mps"] == 3.0 and own["rtl_loiter_s"] == 0

    default_s, own_s = way_home_s(defaults), way_home_s(own)
    print(f"RTL from 200 m: {default_s:.1f} s by the defaults, {own_s:.1f} s by its own figures")
    # 30 m more to climb and to come down, at 3 m/s instead of WPNAV_SPEED, no 5 s loiter.
    assert own_s > default_s + 30
