"""How long a drone takes to fly a list of mission steps, and how much battery it uses.

The Mission Planner (seed 4.2.4) refuses missions a battery cannot finish and shares work by time,
so it needs the flight time of steps before they are flown. This module replays the steps with the
vehicle model the simulator flies too (:mod:`dronefleet.vehicle.kinematics`,
:mod:`dronefleet.vehicle.battery`): trapezoidal legs (2.5 m/s², 10 m/s; climb 2 m/s, descent 1.5
m/s), horizontal and vertical at once; ``wait_for_flight`` ends inside the tolerance cylinder
(Algorithm 1, 2 m) on the Mission Worker's 0.1 s polling, so the next leg starts with the speed
carried from this one. Straight legs are solved in closed form; when a leg turns (speed across the
new direction) the few seconds of the turn are stepped with the simulator's own position
controller. Current: hover, plus forward flight (at its airspeed) and climb, as the sim's battery
model draws it.

Every step is flown, the end action too (issue 28): ``rtl`` as the vehicle flies it home —
its autopilot's own RTL (ArduPilot Copter's ModeRTL: climb above where it is to the return
height, fly home at RTL_SPEED, loiter RTL_LOIT_TIME, land at its land speeds) or, without one,
the companion computer's (drone/navigation.py) — and ``land`` at the autopilot's land speeds. A
steady wind (:attr:`VehicleModel.wind_n_mps`/``wind_e_mps``: an operator's figure or the
autopilot's estimate) slows legs flown against it where the vehicle's airspeed is at its limit,
and is drawn as airspeed.

The estimator's parts: the vehicle (:mod:`.vehicle`), straight legs in closed form
(:mod:`.profile`), its motion (:mod:`.motion`), the current it draws (:mod:`.draw`), the way
home (:mod:`.homing`), the steps replayed (:mod:`.state`, :mod:`.replay`, :mod:`.units`; a
route's units costed kind by kind for the split: :mod:`.repeated`), what an estimate says
(:mod:`.result`) and the fleet's measured draws (:mod:`.fleet_draws`).
"""

from __future__ import annotations

from dronefleet.ground.planner.estimate.fleet_draws import (
    CONSERVATIVE_DRAW_A,
    airframe,
    drone_model,
    fleet_draws,
    with_fleet_draw,
)
from dronefleet.ground.planner.estimate.profile import Profile, rest_to_within_s
from dronefleet.ground.planner.estimate.replay import estimate
from dronefleet.ground.planner.estimate.result import Estimate, Verdict, can_finish, part
from dronefleet.ground.planner.estimate.vehicle import DEFAULT_MODEL, VehicleModel, vehicle_model

__all__ = [
    "CONSERVATIVE_DRAW_A",
    "DEFAULT_MODEL",
    "Estimate",
    "Profile",
    "VehicleModel",
    "Verdict",
    "airframe",
    "can_finish",
    "drone_model",
    "estimate",
    "fleet_draws",
    "part",
    "rest_to_within_s",
    "vehicle_model",
    "with_fleet_draw",
]
