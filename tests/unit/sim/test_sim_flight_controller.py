"""The ``sim`` backend of the FlightController contract, driven through a running world."""

from __future__ import annotations

import pytest

from dronefleet.geo.ned import lla_to_ned, ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.sim import SimWorld
from dronefleet.sim.flight_controller import SimFlightController
from dronefleet.vehicle.base import FcError, FlightController, FlightMode

EXPECTED_KEYS = {
    "lat", "lon", "alt_m", "relative_alt_m", "vn", "ve", "vd", "roll_deg", "pitch_deg",
    "yaw_deg", "battery_pct", "voltage_v", "current_a", "armed", "in_air",
}  # fmt: skip


@pytest.fixture
async def world():
    async with SimWorld(speedup=200) as world:
        yield world


@pytest.fixture
def fc(world: SimWorld, home: LLA) -> SimFlightController:
    world.add_vehicle("QUAD_1", home)
    return world.flight_controller("QUAD_1")


async def test_arm_take_off_fly_100_m_and_land(fc: SimFlightController, world, home) -> None:
    assert isinstance(fc, FlightController)
    await fc.connect()
    started = fc.clock.now()
    await fc.arm()
    assert fc.clock.now() - started == pytest.approx(3.0, abs=0.11)
    assert fc.state().armed
    await fc.takeoff(10.0)
    await fc.clock.sleep(7.0)
    assert fc.position().alt_m == pytest.approx(home.alt_m + 10.0, abs=0.1)
    target = ned_to_lla(NED(60.0, 80.0, -15.0), home)
    await fc.goto(target)
    assert fc.state().mode is FlightMode.GUIDED
    await fc.clock.sleep(16.0)
    reached = lla_to_ned(fc.position(), home)
    assert (reached - NED(60, 80, -15)).norm_m < 0.05
    await fc.land()
    assert fc.state().landing
    await fc.clock.sleep(12.0)
    state = fc.state()
    assert not state.in_air and not state.armed
    await fc.close()


async def test_refusals_carry_the_reason(fc: SimFlightController, home: LLA) -> None:
    with pytest.raises(FcError, match="not armed"):
        await fc.takeoff(10)
    await fc.arm()
    with pytest.raises(FcError, match="below home"):
        await fc.goto(LLA(home.lat, home.lon, home.alt_m - 5))
    await fc.takeoff(5)
    await fc.clock.sleep(1.0)
    with pytest.raises(FcError, match="in the air"):
        await fc.disarm()
    with pytest.raises(FcError, match="reboot"):
        await fc.reboot()


async def test_reboot_takes_about_two_seconds(fc: SimFlightController) -> None:
    started = fc.clock.now()
    await fc.reboot()
    assert fc.clock.now() - started == pytest.approx(2.0, abs=0.11)
    assert (await fc.request_object("FlightStatus"))["Rebooting"] is False


async def test_known_objects_answer_and_unknown_ones_say_what_is_known(fc, home) -> None:
    await fc.arm()
    status = await fc.request_object("FlightStatus")
    assert status["Armed"] == "Armed" and status["FlightMode"] == "STABILIZE"
    gps = await fc.request_object("GPSPosition")
    assert gps["Latitude"] == pytest.approx(home.lat) and gps["Status"] == "Fix3D"
    assert (await fc.request_object("HomeLocation"))["Altitude"] == home.alt_m
    assert (await fc.request_object("PositionActual")) == {"North": 0.0, "East": 0.0, "Down": 0.0}
    assert (await fc.request_object("Accels"))["z"] == pytest.approx(-9.80665)
    battery = await fc.request_object("FlightBatteryState")
    assert battery["NbCells"] == 4 and battery["Voltage"] > 16
    for name in ("AttitudeActual", "VelocityActual"):
        assert await fc.request_object(name)
    with pytest.raises(FcError, match=r"unknown object 'Nope'; known: .*GPSPosition"):
        await fc.request_object("Nope")


async def test_telemetry_streams_flat_numbers_at_5_hz_vehicle_time(fc: SimFlightController):
    samples = []
    async for sample in fc.telemetry():
        samples.append(sample)
        if len(samples) == 6:
            break
    assert samples[0].keys() >= EXPECTED_KEYS
    assert all(isinstance(value, float) for value in samples[0].values())
    times = [s["vehicle_time_s"] for s in samples]
    assert times[-1] - times[0] == pytest.approx(1.0, abs=0.06)


async def test_gps_and_wind_are_what_the_simulated_world_has(world: SimWorld, home: LLA) -> None:
    from dronefleet.sim.wind import Wind
    from dronefleet.vehicle.base import GpsFix

    world.add_vehicle("WINDY", home, wind=Wind.from_direction(6.0, 250.0))
    windy = world.flight_controller("WINDY")
    await windy.connect()
    await windy.clock.sleep(0.5)
    gps = windy.gps()
    assert gps.fix is GpsFix.FIX_3D and gps.satellites == 12 and gps.hdop == 0.8
    wind = windy.wind()
    assert wind.speed_mps == pytest.approx(6.0) and wind.from_deg == pytest.approx(250.0)
