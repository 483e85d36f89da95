"""The current a vehicle draws in the air, as the simulator's battery model draws it
(:mod:`dronefleet.vehicle.battery`): hover, plus forward flight at its airspeed, plus climb (less
in descent) — or the mean draw measured on the vehicle (``VehicleModel.flight_current_a``)."""

from __future__ import annotations

from dronefleet.ground.planner.estimate.vehicle import VehicleModel
from dronefleet.vehicle.battery import Battery

_B = Battery()
_FORWARD = _B.flight_current_a(1.0, 0.0, 1.0) / _B.hover_current_a - 1.0
_CLIMB = _B.flight_current_a(0.0, 1.0, 1.0) / _B.hover_current_a - 1.0
_DESCENT = 1.0 - _B.flight_current_a(0.0, -1.0, 1.0) / _B.hover_current_a


def charged_in_air(
    charge_as: float,
    model: VehicleModel,
    flying_s: float,
    slow_s: float,
    airspeed2: float,
    climb_m: float,
) -> float:
    """``charge_as`` (ampere-seconds drawn) after ``flying_s`` seconds of flight and ``slow_s``
    in the slow last stage of a landing (drawn as hovering), with ``airspeed2`` the integral of
    airspeed² over the flight and ``climb_m`` the height it gained (negative: lost)."""
    m = model
    if m.flight_current_a is not None:
        return charge_as + m.flight_current_a * (flying_s + slow_s)
    hover = m.hover_current_a
    a2 = airspeed2 + (m.wind_n_mps**2 + m.wind_e_mps**2) * slow_s  # hovering in the wind
    charge_as += hover * (flying_s + slow_s) + hover * _FORWARD * a2 / m.max_speed_mps**2
    charge_as += hover * (_CLIMB * climb_m if climb_m > 0 else _DESCENT * climb_m)
    return charge_as
