"""The link's watchdog, stream rates and the payload (CO2 and camera) over MAVLink."""

from __future__ import annotations

import asyncio
import itertools

import pytest

from dronefleet.drone.fc.mavlink import open_flight_controller, payload
from dronefleet.vehicle.base import FcError

from .conftest import HOME

pytestmark = pytest.mark.integration


def url(endpoint) -> str:
    return f"udpout:127.0.0.1:{endpoint.port}"


async def wait_wall(predicate, timeout_s: float = 5.0) -> None:
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout_s
    while not predicate():
        assert loop.time() < deadline, "condition not met in time"
        await asyncio.sleep(0.02)


async def test_a_silent_autopilot_is_reported_lost_and_found_again(sim_fleet):
    async with sim_fleet(1, speedup=10) as server:
        endpoint = server.endpoints[0]
        fc = await open_flight_controller(url(endpoint), heartbeat_timeout_s=0.5)
        try:
            endpoint.close()  # the radio goes quiet
            await wait_wall(lambda: not fc.link.link_ok)
            with pytest.raises(FcError, match=r"not connected .* last heartbeat"):
                await fc.arm()
            assert (await fc.request_object("FlightStatus"))["Link"] == "Lost"
            await endpoint.start()  # and comes back on the same port
            await wait_wall(lambda: fc.link.link_ok)
            await fc.arm()
            assert fc.state().armed
        finally:
            await fc.close()


async def test_stream_rates_follow_set_message_interval_in_vehicle_time(sim_fleet):
    async with sim_fleet(1, speedup=20) as server:
        fc = await open_flight_controller(
            url(server.endpoints[0]), streams_hz={"GLOBAL_POSITION_INT": 2.0, "ATTITUDE": 0}
        )
        try:
            stamps: list[int] = []
            attitudes: list[int] = []

            def count(msg) -> None:
                if msg.get_type() == "GLOBAL_POSITION_INT":
                    stamps.append(msg.time_boot_ms)
                elif msg.get_type() == "ATTITUDE":
                    attitudes.append(msg.time_boot_ms)

            fc.link.add_listener(count)
            await fc.clock.sleep(10.0)
            periodic = [b - a for a, b in itertools.pairwise(stamps) if b - a > 100]
            assert len(stamps) == pytest.approx(20, abs=3)  # 2 Hz for 10 vehicle seconds
            assert sorted(periodic)[len(periodic) // 2] == pytest.approx(500, abs=60)
            assert attitudes == []  # interval -1: stopped
        finally:
            await fc.close()


async def test_co2_and_pictures_come_over_mavlink(sim_fleet):
    plume = (HOME.lat, HOME.lon, 2000.0, 30.0)
    async with sim_fleet(1, speedup=20, plumes=[plume]) as server:
        fc = await open_flight_controller(url(server.endpoints[0]))
        try:
            sensors, camera = payload(fc)
            await wait_wall(lambda: "CO2" in fc.named_values)
            reading = sensors["CO2"].read()
            assert reading.unit == "ppm" and reading.value > 1000  # near the plume's centre
            shot = await camera.capture()
            assert shot["index"] == 1
            await wait_wall(lambda: fc.captures)
            assert fc.captures[0]["lat"] == pytest.approx(fc.position().lat, abs=1e-5)
            assert server.endpoints[0].copter.picture_count == 1
        finally:
            await fc.close()


async def test_a_photo_on_a_vehicle_without_a_camera_fails_with_the_reason(sim_fleet):
    # SITL with CAM1_TYPE 0 answers IMAGE_START_CAPTURE with FAILED: no picture may be reported.
    async with sim_fleet(1, speedup=20) as server:
        server.endpoints[0].copter.camera = None
        fc = await open_flight_controller(url(server.endpoints[0]))
        try:
            _, camera = payload(fc)
            with pytest.raises(FcError, match=r"no picture taken: .*refused \(FAILED\)"):
                await camera.capture()
            assert fc.captures == []
        finally:
            await fc.close()
