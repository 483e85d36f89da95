"""What a drone tells the planner it draws in the air (issue 17): the charge its autopilot reports
used while airborne over the time airborne, not the dissertation quad's 18 A."""

from __future__ import annotations

import pytest

from dronefleet.drone.draw import MIN_AIRBORNE_S, FlightDraw
from dronefleet.ground.planner.estimate import VehicleModel, estimate


def test_the_mean_is_charge_over_airborne_time_across_flights():
    draw = FlightDraw()
    assert draw.mean_a is None
    draw.sample(0.0, 100.0, 0.5, in_air=False)  # on the ground: not counted
    for k in range(13):  # 60 s airborne at 28 A: 28 A x 5 s = 38.9 mAh per sample
        draw.sample(10.0 + 5 * k, 100.0 + 38.888 * k, 28.0, in_air=True)
    draw.sample(80.0, 700.0, 0.5, in_air=False)  # landed; the gap is not flight
    for k in range(5):  # a second flight at 30 A
        draw.sample(200.0 + 5 * k, 800.0 + 41.667 * k, 30.0, in_air=True)
    assert draw.airborne_s == pytest.approx(80.0)
    assert draw.mean_a == pytest.approx((28 * 60 + 30 * 20) / 80, rel=1e-3)


def test_without_a_used_charge_a_running_mean_of_the_current_stands_in():
    draw = FlightDraw()
    for k in range(4):
        draw.sample(5.0 * k, None, 26.0, in_air=True)
    assert draw.airborne_s == 0 and draw.mean_a == pytest.approx(26.0)
    short = FlightDraw()
    short.sample(0.0, 10.0, 20.0, in_air=True)
    short.sample(MIN_AIRBORNE_S / 2, 10.0 + 40.0, 20.0, in_air=True)
    assert short.mean_a == pytest.approx(20.0)  # too short to trust the charge yet


def test_a_measured_draw_replaces_the_quad_model_in_the_battery_estimate():
    from dronefleet.geo.types import LLA

    home = LLA(40.63, -8.659, 10.0)
    steps = [
        {"command": "arm"},
        {"command": "takeoff", "value": 10},
        {"command": "wait_for_flight"},
        {"command": "sleep", "value": 60},
        {"command": "land"},
        {"command": "wait_for_flight"},
    ]
    model = VehicleModel.of_vehicle({"flight_current_a": 28.0, "capacity_mah": 3300})
    measured = estimate(steps, home, home, airborne=False, model=model)
    quad = estimate(steps, home, home, airborne=False, model=VehicleModel(capacity_mah=3300))
    airborne_s = measured.duration_s - 3.0  # less arming (the last step ends on the ground)
    assert measured.energy_mah == pytest.approx(28.0 * airborne_s / 3.6, rel=0.05)
    assert measured.energy_mah / quad.energy_mah == pytest.approx(28 / 18, rel=0.1)
