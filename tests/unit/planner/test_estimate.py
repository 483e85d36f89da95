"""The planner's time and battery estimate agrees with the simulator that flies the steps."""

from __future__ import annotations

import inspect
from typing import Any

import pytest

from dronefleet.drone.config import DroneConfig
from dronefleet.drone.navigation import Tolerance, reached
from dronefleet.geo.ned import lla_to_ned
from dronefleet.geo.types import LLA, NED
from dronefleet.ground.planner.coverage import AreaSpec, plan_area
from dronefleet.ground.planner.estimate import (
    DEFAULT_MODEL,
    Profile,
    can_finish,
    estimate,
    rest_to_within_s,
)
from dronefleet.sim.vehicle import SimVehicle
from dronefleet.sim.world import SimWorld
from dronefleet.vehicle.battery import Battery

POLL_S = 0.1  # the Mission Worker's wait_for_flight polling (DroneConfig.wait_poll_s)


class Camera:
    """The Drone Controller's distance trigger (polled every sim step), counting pictures."""

    def __init__(self, vehicle: SimVehicle) -> None:
        self.vehicle, self.distance_m, self.travelled_m, self.pictures = vehicle, 0.0, 0.0, 0
        self.last = vehicle.position_ned

    def set(self, distance_m: float) -> None:
        self.distance_m, self.travelled_m = distance_m, 0.0
        self.last = self.vehicle.position_ned
        self.pictures += distance_m > 0  # the first picture where the trigger is set

    def poll(self) -> None:
        here = self.vehicle.position_ned
        if self.distance_m > 0:
            self.travelled_m += (here - self.last).horizontal_m
            if self.travelled_m >= self.distance_m:
                self.travelled_m -= self.distance_m
                self.pictures += 1
        self.last = here


def fly(world: SimWorld, vehicle: SimVehicle, steps: list[dict[str, Any]], camera=None) -> list:
    """A tiny Mission Worker: each step on the vehicle, time moved by the world, no broker."""
    home, goal, took = vehicle.home, None, []
    camera = camera or Camera(vehicle)

    def advance(duration_s: float) -> None:
        for _ in range(round(duration_s / world.step_s)):
            world.tick()
            camera.poll()

    for step in steps:
        began, command = world.clock.now(), step["command"]
        if command == "arm":
            vehicle.arm()
            while vehicle.arming:
                advance(world.step_s)
        elif command == "takeoff":
            vehicle.takeoff(step["value"])
            here = vehicle.position_ned
            goal = NED(here.n, here.e, -step["value"])
        elif command == "navigate":
            goal = lla_to_ned(
                LLA(step["lat"], step["lon"], home.alt_m + step["altitude_delta"]), home
            )
            vehicle.goto(goal)
        elif command == "land":
            vehicle.land()
            goal = None
        elif command == "wait_for_flight":
            tol = Tolerance(step.get("horizontal_tolerance_m") or 2.0, 2.0)
            while vehicle.in_air if goal is None else not reached(goal, vehicle.position_ned, tol):
                advance(POLL_S)
        elif command in ("sleep", "read_sensors"):
            advance(step["value"])
        elif command == "takepic":
            camera.pictures += 1
            advance(DEFAULT_MODEL.picture_s)
        elif command == "camera_trigger":
            camera.set(step["value"])
        took.append(world.clock.now() - began)
    return took


def hovering(origin: LLA, at: NED) -> tuple[SimWorld, SimVehicle]:
    world = SimWorld(step_s=0.05)
    vehicle = world.add_vehicle("QUAD_1", origin)
    vehicle.arm()
    world.advance(3.0)
    vehicle.goto(at)
    world.advance(30.0)
    return world, vehicle


def compare(world: SimWorld, vehicle: SimVehicle, steps, *, airborne: bool, camera=None):
    battery = vehicle.battery
    start, before_mah = vehicle.position_lla, battery.consumed_mah
    est = estimate(steps, start, vehicle.home, airborne=airborne, battery_pct=battery.remaining_pct)
    took = fly(world, vehicle, steps, camera)
    return est, sum(took), battery.consumed_mah - before_mah


@pytest.mark.parametrize("fly_through", [False, True])
def test_the_seed_survey_takes_as_long_as_the_estimate_says(origin, rect, fly_through):
    # 5.2: 32 x 64 m at 8 m, 45 photos, the drone hovering ~60 m from the first waypoint.
    spec = AreaSpec(
        polygon=rect(32, 64, north0=50),
        spacing_m=8,
        grid="seed",
        angle_deg=0,
        action="takepic",
        fly_through=fly_through,
    )
    plan = plan_area(spec)
    world, vehicle = hovering(origin, NED(-10, 0, -10))  # 60 m from the first waypoint
    camera = Camera(vehicle)
    steps = plan.mission_steps()
    est, sim_s, sim_mah = compare(world, vehicle, steps, airborne=True, camera=camera)
    assert camera.pictures == plan.photo_count == 45
    assert est.duration_s == pytest.approx(sim_s, rel=0.03)
    assert est.energy_mah == pytest.approx(sim_mah, rel=0.03)
    assert est.battery_end_pct == pytest.approx(vehicle.battery.remaining_pct, abs=0.5)
    if fly_through:  # docs/DESIGN.md §10: 76 s kinematic bound photographing on the fly
        assert sim_s <= 1.2 * 76


@pytest.mark.parametrize("climb_first", [True, False])
def test_a_disarmed_drone_called_100_m_away(origin, at, climb_first):
    # 5.1: arm, climb to 10 m, fly 100 m (the seed's way) or climb while flying (ours).
    target = at(0, 100)
    steps = [{"command": "arm"}, {"command": "takeoff", "value": 10.0}]
    if climb_first:
        steps.append({"command": "wait_for_flight"})
    steps += [
        {"command": "navigate", "lat": target.lat, "lon": target.lon, "altitude_delta": 10.0},
        {"command": "wait_for_flight"},
    ]
    world = SimWorld(step_s=0.05)
    vehicle = world.add_vehicle("QUAD_1", origin)
    est, sim_s, sim_mah = compare(world, vehicle, steps, airborne=False)
    assert est.duration_s == pytest.approx(sim_s, rel=0.03)
    assert est.energy_mah == pytest.approx(sim_mah, rel=0.05)
    assert est.per_step[0] == 3.0  # arming


def test_sensing_holds_and_landing(origin, rect):
    spec = AreaSpec(
        polygon=rect(28, 35), spacing_m=7, grid="seed", angle_deg=0, action="read_sensors", hold_s=2
    )
    steps = [*plan_area(spec).mission_steps(), {"command": "land"}, {"command": "wait_for_flight"}]
    world, vehicle = hovering(origin, NED(-20, -20, -10))
    est, sim_s, sim_mah = compare(world, vehicle, steps, airborne=True)
    assert est.duration_s == pytest.approx(sim_s, rel=0.03)
    assert est.energy_mah == pytest.approx(sim_mah, rel=0.03)
    assert not vehicle.in_air and not vehicle.armed


def test_the_vehicle_model_is_the_simulators():
    params = inspect.signature(SimVehicle.__init__).parameters
    m = DEFAULT_MODEL
    for name in (
        "max_speed_mps",
        "max_climb_mps",
        "max_descent_mps",
        "accel_mps2",
        "accel_z_mps2",
        "arming_s",
        "capacity_mah",
        "hover_current_a",
        "idle_current_a",
    ):
        assert getattr(m, name) == params[name].default, name
    battery = inspect.signature(Battery.__init__).parameters
    assert m.armed_idle_current_a == battery["armed_idle_current_a"].default
    config = DroneConfig(drone_id="QUAD_1")
    assert m.horizontal_tolerance_m == config.horizontal_tolerance_m
    assert m.vertical_tolerance_m == config.vertical_tolerance_m
    assert m.poll_s == config.wait_poll_s
    assert m.takeoff_altitude_m == config.takeoff_altitude_m


def test_trapezoidal_legs():
    # 100 m from rest: 4 s up to 10 m/s (20 m), 6 s cruising, 4 s braking (20 m) = 14 s.
    assert Profile(100, 0, 10, 2.5).duration == pytest.approx(14)
    assert rest_to_within_s(100, 2.0, 10, 2.5) == pytest.approx(14 - (2 * 2 / 2.5) ** 0.5)
    assert Profile(8, 0, 10, 2.5).duration == pytest.approx(2 * (8 / 2.5) ** 0.5)
    x, v, _ = Profile(10, 5, 10, 2.5).at(100)
    assert (x, v) == (10, 0)


def test_a_low_battery_cannot_finish_and_says_why(origin, rect):
    steps = plan_area(AreaSpec(polygon=rect(200, 300), spacing_m=5)).mission_steps()
    est = estimate(
        steps, LLA(origin.lat, origin.lon, origin.alt_m + 10), origin, airborne=True, battery_pct=40
    )
    ok, why = can_finish(est, reserve_pct=20)
    assert not ok
    assert "reserve" in why and "40.0%" in why
    short = estimate(
        steps[:6],
        LLA(origin.lat, origin.lon, origin.alt_m + 10),
        origin,
        airborne=True,
        battery_pct=40,
    )
    assert can_finish(short, reserve_pct=20).ok
