"""A battery swap at home (issue 29): ``dronefleet demo --recharge-s S`` gives a drone that has
stood disarmed on the ground at its home for S vehicle seconds a full pack, so a handover can
happen in the demo. Off by default (``recharge_s=None``), as in the experiments."""

from __future__ import annotations

import pytest

from dronefleet.geo.types import NED
from dronefleet.sim import SimVehicle


def _flown_down(vehicle: SimVehicle, fly, *, to: NED | None = None) -> float:
    """Arm, climb to 10 m, hover a minute (over ``to`` if given), land; the charge left."""
    vehicle.arm()
    fly(vehicle, until=lambda: vehicle.armed)
    vehicle.takeoff(10.0)
    fly(vehicle, until=lambda: vehicle.relative_alt_m > 9.9)
    if to is not None:
        vehicle.goto(to)
        fly(vehicle, until=lambda: vehicle.position_ned.n > 29.9 and not vehicle.velocity_ned.n)
    fly(vehicle, for_s=60.0)
    vehicle.land()
    fly(vehicle, until=lambda: not vehicle.in_air and not vehicle.armed)
    left = vehicle.battery.remaining_pct
    assert left < 95.0
    return left


def test_a_drone_disarmed_at_home_for_the_recharge_time_gets_a_full_battery(home, fly):
    vehicle = SimVehicle("QUAD_1", home, recharge_s=30.0)
    left = _flown_down(vehicle, fly)
    fly(vehicle, for_s=29.0)
    assert vehicle.battery.remaining_pct < left  # not yet: the idle current still draws
    fly(vehicle, for_s=1.1)
    assert vehicle.battery.remaining_pct == pytest.approx(100.0, abs=0.01)
    assert vehicle.battery.consumed_mah < 1.0  # a new pack: its own count
    vehicle.arm()  # and it flies again
    fly(vehicle, until=lambda: vehicle.armed)


def test_no_swap_without_the_option_away_from_home_or_armed(home, fly):
    off = SimVehicle("QUAD_1", home)  # the experiments' vehicles: never recharged
    left = _flown_down(off, fly)
    fly(off, for_s=120.0)
    assert off.battery.remaining_pct < left

    away = SimVehicle("QUAD_2", home, recharge_s=10.0)
    left = _flown_down(away, fly, to=NED(30.0, 0.0, -10.0))  # landed 30 m from home
    fly(away, for_s=60.0)
    assert away.battery.remaining_pct < left

    armed = SimVehicle("QUAD_3", home, recharge_s=10.0)
    _flown_down(armed, fly)
    armed.arm()
    fly(armed, until=lambda: armed.armed)
    left = armed.battery.remaining_pct
    fly(armed, for_s=30.0)  # armed on the pad: nobody swaps a pack under spinning props
    assert armed.battery.remaining_pct < left


def test_a_swap_ends_the_battery_failsafe(home, fly):
    vehicle = SimVehicle("QUAD_1", home, recharge_s=5.0, initial_charge_pct=8.0)
    vehicle.arm()
    fly(vehicle, until=lambda: vehicle.armed)
    vehicle.takeoff(10.0)
    fly(vehicle, until=lambda: vehicle.battery_failsafe)  # 5 %: it lands by itself
    fly(vehicle, until=lambda: not vehicle.in_air and not vehicle.armed)
    fly(vehicle, for_s=5.1)
    assert vehicle.battery.remaining_pct == pytest.approx(100.0, abs=0.01)
    assert not vehicle.battery_failsafe
    vehicle.arm()
    fly(vehicle, until=lambda: vehicle.armed)
