"""Mode encodings (ArduPilot Copter numbers, PX4 main/sub modes) and the autopilot's clock."""

from __future__ import annotations

import asyncio

import pytest

from dronefleet.drone.fc.clock import AutopilotClock
from dronefleet.protocols.mavlink.modes import (
    Autopilot,
    CopterMode,
    Px4Auto,
    Px4Main,
    custom_mode_for,
    decode_mode,
    mode_name,
    px4_custom_mode,
    set_mode_params,
)
from dronefleet.vehicle.base import FlightMode


@pytest.mark.parametrize("autopilot", [Autopilot.ARDUPILOT, Autopilot.PX4])
@pytest.mark.parametrize("mode", list(FlightMode))
def test_every_flight_mode_round_trips_through_custom_mode(autopilot, mode):
    custom = custom_mode_for(autopilot, mode)
    expected = FlightMode.HOLD if autopilot is Autopilot.PX4 and mode is FlightMode.GUIDED else mode
    assert decode_mode(autopilot, custom) is expected


def test_ardupilot_copter_numbers():
    assert custom_mode_for(Autopilot.ARDUPILOT, FlightMode.GUIDED) == 4
    assert custom_mode_for(Autopilot.ARDUPILOT, FlightMode.MISSION) == CopterMode.AUTO == 3
    assert custom_mode_for(Autopilot.ARDUPILOT, FlightMode.HOLD) == CopterMode.BRAKE == 17
    assert set_mode_params(Autopilot.ARDUPILOT, FlightMode.LAND) == (1.0, 9.0, 0.0)
    assert decode_mode(Autopilot.ARDUPILOT, CopterMode.LOITER) is FlightMode.HOLD
    assert decode_mode(Autopilot.ARDUPILOT, 99) is FlightMode.STABILIZE
    assert mode_name(Autopilot.ARDUPILOT, 6) == "RTL"


def test_px4_packs_main_and_sub_mode_in_the_high_bytes():
    mission = px4_custom_mode(Px4Main.AUTO, Px4Auto.MISSION)
    assert mission == (4 << 16) | (4 << 24)
    assert decode_mode(Autopilot.PX4, mission) is FlightMode.MISSION
    assert decode_mode(Autopilot.PX4, px4_custom_mode(Px4Main.OFFBOARD)) is FlightMode.GUIDED
    assert mode_name(Autopilot.PX4, px4_custom_mode(Px4Main.AUTO, Px4Auto.RTL)) == "AUTO.RTL"
    assert set_mode_params(Autopilot.PX4, FlightMode.RTL) == (1.0, 4.0, 5.0)


def test_clock_follows_boot_time_at_the_observed_rate():
    clock = AutopilotClock()
    for i in range(20):  # 20 vehicle seconds per wall second
        clock.observe(i * 1000, wall=1000.0 + i * 0.05)
    assert clock.speedup == pytest.approx(20.0)
    assert clock.synced


def test_clock_never_runs_backwards_across_a_reboot():
    clock = AutopilotClock()
    clock.observe(50_000, wall=0.0)
    before = clock.now()
    clock.observe(200, wall=0.1)  # rebooted: boot time starts again
    assert clock.boot_count == 1
    assert clock.now() >= before
    clock.observe(1200, wall=0.2)
    assert clock.now() >= 51.0


async def test_sleep_waits_vehicle_seconds():
    clock = AutopilotClock()
    clock.observe(0)
    loop = asyncio.get_running_loop()
    start_wall, start = loop.time(), clock.now()
    await clock.sleep(0.1)
    assert clock.now() - start >= 0.1
    assert loop.time() - start_wall == pytest.approx(0.1, abs=0.08)  # rate 1 when alone
