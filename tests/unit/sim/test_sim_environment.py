"""The vehicle's surroundings: battery, GPS and wind."""

from __future__ import annotations

import itertools
import statistics

import pytest

from dronefleet.geo.ned import lla_to_ned
from dronefleet.geo.types import NED
from dronefleet.sim import SimVehicle, VehicleError, Wind
from dronefleet.vehicle.base import FlightMode


def test_a_full_pack_reads_16_8_v_and_sags_under_load(home, hovering) -> None:
    assert SimVehicle("fresh", home).battery_state.voltage_v == pytest.approx(16.8, 0.01)
    state = hovering.battery_state
    assert state.cell_count == 4 and state.capacity_mah == 5500
    assert state.current_a == pytest.approx(18.0, rel=0.05)
    assert state.voltage_v < 16.8 - 0.3


def test_battery_drains_faster_in_forward_flight_than_in_hover(home, fly) -> None:
    hoverer, cruiser = SimVehicle("H", home), SimVehicle("C", home)
    for v in (hoverer, cruiser):
        v.arm()
        fly(v, until=lambda v=v: v.armed)
        v.takeoff(10)
        fly(v, for_s=8)
    start_h, start_c = hoverer.battery.consumed_mah, cruiser.battery.consumed_mah
    cruiser.goto(NED(1000, 0, -10))
    fly(hoverer, for_s=60)
    fly(cruiser, for_s=60)
    hover_mah = hoverer.battery.consumed_mah - start_h
    cruise_mah = cruiser.battery.consumed_mah - start_c
    assert hover_mah == pytest.approx(18.0 * 60 / 3.6, rel=0.02)
    assert cruise_mah > 1.3 * hover_mah


def test_an_empty_battery_lands_the_vehicle_by_itself(home, fly) -> None:
    low = SimVehicle("LOW", home, initial_charge_pct=7.0)
    low.arm()
    fly(low, until=lambda: low.armed)
    low.goto(NED(0, 0, -20))
    fly(low, until=lambda: low.battery_failsafe, timeout_s=300)
    assert low.landing and low.mode is FlightMode.LAND
    with pytest.raises(VehicleError, match="failsafe"):
        low.goto(NED(50, 0, -20))
    fly(low, until=lambda: not low.in_air)
    assert not low.armed and low.position_ned.d == 0.0
    with pytest.raises(VehicleError, match="battery at"):
        low.arm()


def test_an_empty_battery_refuses_to_arm(home) -> None:
    with pytest.raises(VehicleError, match="charge or swap"):
        SimVehicle("FLAT", home, initial_charge_pct=4.0).arm()


def test_gps_fixes_come_at_5_hz(hovering, fly) -> None:
    hovering.goto(NED(50, 0, -10))
    fix_times = []
    last = hovering.gps.fix_time_s

    def record() -> None:
        nonlocal last
        if hovering.gps.fix_time_s != last:
            last = hovering.gps.fix_time_s
            fix_times.append(last)

    fly(hovering, for_s=2.0, on_step=record)
    assert len(fix_times) == 10
    gaps = [b - a for a, b in itertools.pairwise(fix_times)]
    assert all(g == pytest.approx(0.2) for g in gaps)
    # between fixes the reported position lags the true one
    fix = lla_to_ned(hovering.gps_lla, hovering.home)
    assert fix.n <= hovering.position_ned.n


def test_gps_noise_is_seeded_and_has_the_requested_spread(home, fly) -> None:
    def fixes(seed: int) -> list[float]:
        v = SimVehicle("N", home, gps_noise_m=2.0, seed=seed)
        out = []
        for _ in range(400):
            fly(v, for_s=0.2)
            out.append(lla_to_ned(v.gps_lla, home).n)
        return out

    a, b = fixes(7), fixes(7)
    assert a == b
    assert statistics.pstdev(a) == pytest.approx(2.0, rel=0.2)
    assert abs(statistics.fmean(a)) < 0.5


def test_headwind_slows_the_ground_speed_and_costs_current(home, fly) -> None:
    north_wind = Wind.from_direction(5.0, from_deg=0.0)  # blows from the north, to the south
    assert north_wind.n_mps == pytest.approx(-5.0)
    calm, windy = SimVehicle("CALM", home), SimVehicle("WINDY", home, wind=north_wind)
    for v in (calm, windy):
        v.arm()
        fly(v, until=lambda v=v: v.armed)
        v.takeoff(10)
        fly(v, for_s=8)
    assert windy.position_ned.horizontal_m < 0.01  # holds its spot against the wind
    assert windy.battery_state.current_a > calm.battery_state.current_a
    for v in (calm, windy):
        v.goto(NED(300, 0, -10))
        fly(v, for_s=15)
    assert calm.velocity_ned.n == pytest.approx(10.0)
    assert windy.velocity_ned.n == pytest.approx(5.0, abs=0.01)
    fly(windy, until=lambda: windy.position_ned == NED(300, 0, -10))  # still gets there
