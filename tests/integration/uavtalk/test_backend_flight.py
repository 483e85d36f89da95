"""The uavtalk backend flies a simulated dRonin over real UAVTalk bytes on loopback TCP.

Seed 4.1.2: arm, take off, fly to a coordinate sent as a NED waypoint relative to home
(Figure 4.13), land; UAVObjects on request; refusals come back as NACKs with the vehicle's reason.
"""

from __future__ import annotations

import asyncio
import contextlib
import time

import pytest

from dronefleet.drone.fc.uavtalk import Refused, UAVTalkLink, open_flight_controller
from dronefleet.geo.ned import lla_to_ned, ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.protocols.uavtalk.framing import Frame, FrameParser, MessageType, encode_frame
from dronefleet.protocols.uavtalk.registry import default_registry
from dronefleet.sim.uavtalk import UAVTalkServer
from dronefleet.sim.world import SimWorld
from dronefleet.vehicle.base import FcError

pytestmark = pytest.mark.integration

HOME = LLA(40.63, -8.659, 10.0)
SPEEDUP = 20.0


@contextlib.asynccontextmanager
async def simulated_dronin(**vehicle):
    async with SimWorld(speedup=SPEEDUP) as world:
        world.add_vehicle("UAVT_1", HOME, **vehicle)
        async with UAVTalkServer(world) as server:
            yield world, server.endpoints["UAVT_1"]


async def until(fc, predicate, timeout_s=60.0):
    """Wait on the backend's own (vehicle) clock until ``predicate()``."""
    deadline = fc.clock.now() + timeout_s
    while not predicate():
        assert fc.clock.now() < deadline, "condition not met in time"
        await fc.clock.sleep(0.2)


async def test_arm_takeoff_goto_100m_and_land_over_uavtalk():
    async with simulated_dronin() as (world, url):
        vehicle = world.vehicles["UAVT_1"]
        fc = await open_flight_controller(url)
        try:
            wall0, sim0 = time.monotonic(), world.clock.now()
            assert (lla_to_ned(fc.home(), HOME)).norm_m < 0.02  # 1e-7 degree resolution

            with pytest.raises(FcError, match="not armed"):
                await fc.takeoff(10)

            started = fc.clock.now()
            await fc.arm()
            assert fc.state().armed and vehicle.armed
            # 3 vehicle seconds, seen on the next FlightStatus update (a stall of a loaded host
            # adds a little more vehicle time, never less).
            assert 2.9 <= fc.clock.now() - started <= 4.5

            await fc.takeoff(10)
            await until(fc, lambda: fc.position().alt_m - HOME.alt_m > 9.8)

            target = ned_to_lla(NED(80.0, 60.0, -10.0), HOME)  # 100 m away
            await fc.goto(target)
            # The autopilot got a NED waypoint relative to home, not a coordinate.
            sent = world_waypoint(world)
            expected = lla_to_ned(target, HOME)
            assert abs(sent.n - expected.n) < 0.02 and abs(sent.e - expected.e) < 0.02
            assert sent.d == pytest.approx(-10.0, abs=1e-4)
            await until(fc, lambda: (lla_to_ned(fc.position(), HOME) - expected).norm_m < 1.0)

            with pytest.raises(Refused, match="land first"):
                await fc.disarm()

            await fc.land()
            await until(fc, lambda: not fc.state().in_air)
            assert not fc.state().armed
            assert lla_to_ned(vehicle.position_lla, HOME).horizontal_m == pytest.approx(100, abs=1)

            sim_s, wall_s = world.clock.now() - sim0, time.monotonic() - wall0
            # Vehicle time, not wall time: clearly faster than real time even on a loaded host.
            assert sim_s / wall_s > 3, f"{sim_s:.1f} vehicle s in {wall_s:.1f} wall s"
            assert fc.clock.speedup > 3
            assert abs(fc.clock.now() - vehicle.time_s) < 0.5
        finally:
            await fc.close()


def world_waypoint(world) -> NED:
    target = world.vehicles["UAVT_1"].target_ned
    assert target is not None
    return target


async def test_objrequest_returns_decoded_objects():
    async with simulated_dronin() as (_world, url):
        fc = await open_flight_controller(url)
        try:
            gps = await fc.request_object("GPSPosition")
            assert gps["Latitude"] == pytest.approx(HOME.lat, abs=1e-7)
            assert gps["Longitude"] == pytest.approx(HOME.lon, abs=1e-7)
            assert gps["Altitude"] == pytest.approx(HOME.alt_m)
            assert gps["Status"] == "Fix3D" and gps["Satellites"] > 4
            attitude = await fc.request_object("AttitudeActual")
            assert set(attitude) >= {"Roll", "Pitch", "Yaw", "q1", "q2", "q3", "q4"}
            assert attitude["q1"] == pytest.approx(1.0, abs=1e-6)  # level on the ground
            status = await fc.request_object("FlightStatus")
            assert status["Armed"] == "Disarmed" and status["InAir"] is False
            battery = await fc.request_object("FlightBatteryState")
            assert battery["NbCells"] == 4 and battery["Capacity"] == pytest.approx(5500)
            with pytest.raises(FcError, match="unknown object"):
                await fc.request_object("NoSuchObject")
            sample = await anext(fc.telemetry())
            assert sample["lat"] == pytest.approx(HOME.lat) and sample["armed"] == 0.0
        finally:
            await fc.close()


async def test_refusals_carry_the_vehicles_reason():
    async with simulated_dronin(initial_charge_pct=3.0) as (_world, url):
        fc = await open_flight_controller(url)
        try:
            with pytest.raises(Refused, match=r"battery at 3\.0 %"):
                await fc.arm()
            with pytest.raises(Refused, match="not armed"):
                await fc.goto(ned_to_lla(NED(10, 0, -5), HOME))
            with pytest.raises(FcError, match="below home"):
                await fc.goto(LLA(HOME.lat, HOME.lon, HOME.alt_m - 5))
            with pytest.raises(Refused, match="read-only"):
                await fc.link.write("GPSPosition", {"Latitude": 0})
        finally:
            await fc.close()


async def test_raw_bytes_nack_unknown_objects_and_survive_noise():
    """A hand-rolled client: unknown ids are NACKed; garbage before a request is skipped."""
    registry = default_registry()
    async with simulated_dronin() as (_world, url):
        host, port = url.removeprefix("tcp:").rsplit(":", 1)
        reader, writer = await asyncio.open_connection(host, int(port))
        parser = FrameParser(registry.multi_instance)
        try:
            writer.write(encode_frame(Frame(MessageType.OBJ_REQ, 0x12345678)))
            gps = registry["GPSPosition"]
            writer.write(
                b"\x3c\x99garbage\x3c\x20\xff" + encode_frame(Frame(MessageType.OBJ_REQ, gps.id))
            )
            seen: list[Frame] = []

            async def wait_for(match):
                while not any(match(f) for f in seen):
                    seen.extend(parser.feed(await asyncio.wait_for(reader.read(4096), 5)))

            await wait_for(lambda f: f.type is MessageType.NACK and f.object_id == 0x12345678)
            await wait_for(lambda f: f.type is MessageType.OBJ and f.object_id == gps.id)
            # Periodic updates flow without asking: attitude at 10 Hz, GPS at 5 Hz.
            att = registry["AttitudeActual"]
            await wait_for(lambda f: f.object_id == att.id)
        finally:
            writer.close()


async def test_link_reconnects_after_the_connection_drops():
    async with SimWorld(speedup=SPEEDUP) as world:
        world.add_vehicle("UAVT_1", HOME)
        server = UAVTalkServer(world)
        await server.start()
        url = server.endpoints["UAVT_1"]
        port = int(url.rsplit(":", 1)[1])
        fc = await open_flight_controller(url)
        try:
            await server.stop()
            await asyncio.sleep(0.3)
            assert not fc.link.connected
            with pytest.raises(FcError, match="down"):
                await fc.request_object("GPSPosition")
            server = UAVTalkServer(world, port=port)
            await server.start()
            for _ in range(100):
                if fc.link.connected:
                    break
                await asyncio.sleep(0.1)
            assert (await fc.request_object("FlightStatus"))["Armed"] == "Disarmed"
        finally:
            await fc.close()
            await server.stop()


async def test_a_second_link_sees_the_same_vehicle():
    async with simulated_dronin() as (_world, url):
        host, port = url.removeprefix("tcp:").rsplit(":", 1)
        fc = await open_flight_controller(url)
        observer = UAVTalkLink(host, int(port))
        await observer.open()
        try:
            await fc.arm()
            status = await observer.request("FlightStatus")
            assert status["Armed"] == "Armed"
        finally:
            await observer.close()
            await fc.close()
