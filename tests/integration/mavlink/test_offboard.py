"""GUIDED velocity and offset targets on the simulated Copter (issue 10, item 4).

The drone's MAVLink backend takes off; a velocity-only SET_POSITION_TARGET_LOCAL_NED then moves
the vehicle at that velocity, and without a new target it brakes and holds after GUID_TIMEOUT
(3 s, ArduPilot's default); a velocity-only SET_POSITION_TARGET_GLOBAL_INT does the same; a
LOCAL_OFFSET_NED position goes that far from where the vehicle is. Before, velocity targets were
refused ("only position targets are supported by the sim").
"""

from __future__ import annotations

import pytest

from dronefleet.drone.fc.mavlink import open_flight_controller
from dronefleet.geo.ned import lla_to_ned
from dronefleet.protocols.mavlink.codec import dialect as mav

from .conftest import HOME
from .test_backend_flies_sim import until, url

pytestmark = pytest.mark.integration

VELOCITY_ONLY = 0b110111000111  # position, acceleration, yaw and yaw rate ignored
POSITION_ONLY = 0b110111111000


async def test_velocity_targets_move_the_vehicle_then_it_holds(sim_fleet):
    async with sim_fleet(1, speedup=20) as server:
        endpoint = server.endpoints[0]
        vehicle = endpoint.copter.vehicle
        fc = await open_flight_controller(url(endpoint))
        try:
            await fc.arm()
            await fc.takeoff(10)
            await until(fc, lambda: vehicle.relative_alt_m > 9.5, what="climb")
            start = vehicle.position_ned
            began = fc.clock.now()
            target = mav.MAVLink_set_position_target_local_ned_message(
                0, 1, 1, mav.MAV_FRAME_LOCAL_NED, VELOCITY_ONLY, 0, 0, 0, 2.0, 0, 0, 0, 0, 0, 0, 0
            )
            fc.link.send(target)
            await until(fc, lambda: fc.clock.now() - began > 2.0, what="two seconds")
            assert vehicle.velocity_ned.n == pytest.approx(2.0, abs=0.3)  # at the velocity asked
            await until(fc, lambda: fc.clock.now() - began > 8.0, what="past GUID_TIMEOUT")
            moved = vehicle.position_ned - start
            assert 4.0 < moved.n < 9.0 and abs(moved.e) < 0.5, moved  # ~3 s at 2 m/s, braked
            assert abs(vehicle.velocity_ned.n) < 0.1  # holding
            east = mav.MAVLink_set_position_target_global_int_message(
                0, 1, 1, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, VELOCITY_ONLY, 0, 0, 0,
                0, 1.5, 0, 0, 0, 0, 0, 0,
            )  # fmt: skip
            fc.link.send(east)
            here = vehicle.position_ned
            await until(fc, lambda: vehicle.velocity_ned.e > 1.3, what="east at 1.5 m/s")
            offset = mav.MAVLink_set_position_target_local_ned_message(
                0, 1, 1, mav.MAV_FRAME_LOCAL_OFFSET_NED, POSITION_ONLY, 10, 0, 0, 0, 0, 0, 0, 0,
                0, 0, 0,
            )  # fmt: skip
            here = vehicle.position_ned
            fc.link.send(offset)
            await until(fc, lambda: abs(vehicle.velocity_ned.n) > 0.5, what="offset start")
            await until(fc, lambda: vehicle.velocity_ned.norm_m < 0.05, what="offset end")
            gone = vehicle.position_ned - here
            assert gone.n == pytest.approx(10.0, abs=1.5), gone
            assert lla_to_ned(fc.position(), HOME).d == pytest.approx(-10, abs=1.0)
        finally:
            await fc.close()
