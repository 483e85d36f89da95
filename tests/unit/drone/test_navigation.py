"""Algorithm 1: a goal is reached inside the tolerance cylinder (Figure 4.15)."""

import pytest

from dronefleet.drone.navigation import Tolerance, reached
from dronefleet.geo.types import NED


@pytest.mark.parametrize(
    ("actual", "expected"),
    [
        (NED(0, 0, -10), True),
        (NED(1.9, 0, -10), True),
        (NED(1.5, 1.5, -10), False),  # 2.12 m horizontally
        (NED(0, 0, -8.1), True),
        (NED(0, 0, -8.0), False),  # exactly 2 m: strict inequality, as in the seed
        (NED(0, 0, -12.5), False),
    ],
)
def test_algorithm_1_cylinder(actual, expected):
    assert reached(NED(0, 0, -10), actual, Tolerance(2, 2)) is expected


def test_tolerances_are_configurable():
    assert reached(NED(0, 0, -10), NED(4, 0, -10), Tolerance(5, 1))
    assert not reached(NED(0, 0, -10), NED(0, 0, -11.5), Tolerance(5, 1))


@pytest.mark.virtual_time
async def test_navigate_right_after_takeoff_waits_until_the_vehicle_is_up():
    # ArduPilot keeps a copter on the ground when a GUIDED target replaces its take-off
    # (issue 17): the Navigation Processor sends no target below SAFE_HEIGHT_M.
    from dronefleet.drone.navigation import SAFE_HEIGHT_M, NavigationProcessor
    from dronefleet.geo.types import LLA
    from dronefleet.sim.world import SimWorld

    async with SimWorld() as world:
        home = LLA(40.63, -8.659, 10.0)
        world.add_vehicle("Q", home, arming_s=0)
        fc = world.flight_controller("Q")
        sent: list[float] = []
        goto = fc.goto

        async def record(target):
            sent.append(fc.position().alt_m - home.alt_m)
            await goto(target)

        fc.goto = record  # type: ignore[method-assign]
        nav = NavigationProcessor(fc)
        await fc.arm()
        await nav.takeoff(10)
        await nav.navigate(40.6303, -8.659, 10)
        assert sent and sent[0] >= SAFE_HEIGHT_M - 0.05


@pytest.mark.virtual_time
async def test_rtl_without_an_autopilot_rtl_flies_home_and_lands():
    from dronefleet.clock import wait_until
    from dronefleet.drone.navigation import NavigationProcessor
    from dronefleet.geo.ned import lla_to_ned
    from dronefleet.geo.types import LLA
    from dronefleet.sim.world import SimWorld

    async with SimWorld() as world:
        home = LLA(40.63, -8.659, 10.0)
        vehicle = world.add_vehicle("Q", home, arming_s=0)
        fc = world.flight_controller("Q")
        nav = NavigationProcessor(fc)
        await fc.arm()
        await nav.navigate(40.6305, -8.6585, 10)  # ~60 m away
        assert await wait_until(fc.clock, nav.goal_reached, timeout_s=60)
        await nav.return_to_launch()
        assert await wait_until(fc.clock, nav.goal_reached, timeout_s=120)
        assert not vehicle.in_air and not vehicle.armed
        assert lla_to_ned(vehicle.position_lla, home).horizontal_m < 2.5
