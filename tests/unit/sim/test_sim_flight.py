"""Flying a simulated quad: the seed's limits (10 m/s, 2 m/s climb, 2.5 m/s², 3 s arming)."""

from __future__ import annotations

import pytest

from dronefleet.geo.types import NED
from dronefleet.sim import SimVehicle, VehicleError
from dronefleet.vehicle.base import FcError, FlightMode


def test_arming_takes_three_seconds(vehicle: SimVehicle, fly) -> None:
    vehicle.arm()
    assert vehicle.arming and not vehicle.armed
    took = fly(vehicle, until=lambda: vehicle.armed)
    assert took == pytest.approx(3.0, abs=0.051)
    assert not vehicle.arming


def test_arming_twice_and_flying_unarmed_are_refused(vehicle: SimVehicle, fly) -> None:
    with pytest.raises(VehicleError, match="not armed"):
        vehicle.takeoff(10)
    vehicle.arm()
    with pytest.raises(VehicleError, match="in progress"):
        vehicle.arm()
    with pytest.raises(VehicleError, match="still arming"):
        vehicle.goto(NED(10, 0, -10))
    fly(vehicle, until=lambda: vehicle.armed)
    with pytest.raises(FcError, match="already armed"):
        vehicle.arm()


def test_climbing_10_m_takes_at_least_5_s_and_ends_on_the_altitude(armed: SimVehicle, fly):
    armed.takeoff(10.0)
    assert armed.in_air and armed.mode is FlightMode.GUIDED
    highest = 0.0

    def track() -> None:
        nonlocal highest
        highest = max(highest, armed.relative_alt_m)
        assert -armed.velocity_ned.d <= 2.0 + 1e-9
        assert armed.position_ned.horizontal_m == 0.0  # vertical climb

    took = fly(armed, until=lambda: armed.velocity_ned.d == 0.0 and highest > 9, on_step=track)
    assert took >= 5.0
    assert took == pytest.approx(10 / 2 + 2 / 2.5, abs=0.2)
    assert armed.relative_alt_m == pytest.approx(10.0, abs=0.1)
    assert highest <= 10.1


def test_100_m_at_10_mps_and_2_5_mps2_takes_14_s_and_stops_on_the_spot(hovering, fly) -> None:
    hovering.goto(NED(100.0, 0.0, -10.0))
    furthest = 0.0
    fastest = 0.0

    def track() -> None:
        nonlocal furthest, fastest
        furthest = max(furthest, hovering.position_ned.n)
        fastest = max(fastest, hovering.velocity_ned.horizontal_m)

    took = fly(
        hovering,
        until=lambda: hovering.position_ned.n > 99 and hovering.velocity_ned.horizontal_m == 0.0,
        on_step=track,
    )
    assert took == pytest.approx(100 / 10 + 10 / 2.5, abs=0.5)
    assert fastest <= 10.0 + 1e-9
    assert furthest - 100.0 <= 0.1
    assert hovering.position_ned.n == pytest.approx(100.0, abs=0.1)


def test_a_diagonal_goto_flies_a_straight_line(hovering, fly) -> None:
    hovering.goto(NED(60.0, 80.0, -10.0))

    def off_the_line() -> None:
        p = hovering.position_ned
        assert abs(p.n * 0.8 - p.e * 0.6) < 0.05  # distance from the line n:e = 60:80

    fly(hovering, until=lambda: hovering.position_ned == NED(60, 80, -10), on_step=off_the_line)


def test_goto_from_the_ground_climbs_while_flying(armed: SimVehicle, fly) -> None:
    """The panic-button profile: climbing and flying at once, 100 m in ~14 s after arming."""
    armed.goto(NED(100.0, 0.0, -10.0))
    fly(armed, for_s=3.0)
    assert armed.position_ned.n > 5 and armed.relative_alt_m > 4
    took = 3.0 + fly(armed, until=lambda: armed.position_ned == NED(100, 0, -10))
    assert took == pytest.approx(14.0, abs=0.5)


def test_hold_brakes_and_stays(hovering, fly) -> None:
    hovering.goto(NED(100.0, 0.0, -10.0))
    fly(hovering, for_s=6.0)  # cruising at 10 m/s
    hovering.hold()
    assert hovering.mode is FlightMode.HOLD
    fly(hovering, for_s=6.0)
    stopped_at = hovering.position_ned
    assert hovering.velocity_ned.norm_m == 0.0
    assert stopped_at.n < 100  # it did not carry on to the old target
    fly(hovering, for_s=5.0)
    assert hovering.position_ned == stopped_at


def test_landing_ends_on_the_ground_and_disarms(hovering, fly) -> None:
    hovering.land()
    assert hovering.landing and hovering.mode is FlightMode.LAND
    fastest_descent = 0.0

    def track() -> None:
        nonlocal fastest_descent
        fastest_descent = max(fastest_descent, hovering.velocity_ned.d)

    took = fly(hovering, until=lambda: not hovering.in_air, on_step=track)
    assert took >= 10 / 1.5
    assert fastest_descent <= 1.5 + 1e-9
    assert hovering.position_ned.d == 0.0
    assert not hovering.armed and not hovering.landing


def test_disarm_in_flight_is_refused_and_forced_disarm_falls(hovering, fly) -> None:
    with pytest.raises(VehicleError, match="in the air"):
        hovering.disarm()
    assert hovering.armed
    hovering.disarm(force=True)
    assert not hovering.armed and hovering.in_air and hovering.falling
    took = fly(hovering, until=lambda: not hovering.in_air)
    assert took < 2.0  # free fall from 10 m: ~1.5 s
    assert hovering.position_ned.d == 0.0 and hovering.velocity_ned.norm_m == 0.0


def test_targets_below_the_minimum_altitude_are_refused(armed: SimVehicle) -> None:
    with pytest.raises(VehicleError, match="use land"):
        armed.goto(NED(10.0, 0.0, 0.0))
    with pytest.raises(VehicleError, match="below"):
        armed.takeoff(-3.0)


def test_reboot_is_refused_in_the_air_and_takes_two_seconds_on_the_ground(hovering, fly):
    with pytest.raises(VehicleError, match="reboot in the air"):
        hovering.reboot()
    hovering.land()
    fly(hovering, until=lambda: not hovering.in_air)
    hovering.reboot()
    with pytest.raises(VehicleError, match="rebooting"):
        hovering.arm()
    assert fly(hovering, until=lambda: not hovering.rebooting) == pytest.approx(2.0, abs=0.06)
    hovering.arm()


def test_attitude_pitches_forward_when_accelerating_and_faces_the_track(hovering, fly) -> None:
    hovering.goto(NED(0.0, 100.0, -10.0))  # due east
    fly(hovering, for_s=1.0)
    attitude = hovering.attitude
    assert attitude.pitch_deg < -10  # nose down
    assert abs(attitude.roll_deg) < 1
    assert attitude.yaw_deg == pytest.approx(90.0)
