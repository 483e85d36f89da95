"""The draw a drone's estimate uses when its own vehicle has not measured one (issue 28): the
mean measured on the fleet's other drones of its airframe, else a conservative figure."""

from __future__ import annotations

from typing import Any

from dronefleet.ground.planner.estimate.vehicle import VehicleModel, vehicle_model

#: The draw assumed in the air for an airframe nobody in the fleet has measured yet (issue 28):
#: above what ArduPilot Copter SITL's quad was measured to draw (about 30 A, drone/draw.py), not
#: the dissertation quad's 18 A hover, so a first flight is not planned on a battery it lacks.
CONSERVATIVE_DRAW_A = 32.0


#: Figures of a vehicle that are not its airframe: the measured draw, and how it flies home
#: (a different RTL_ALT is a setting, not another vehicle).
_NOT_AIRFRAME = frozenset(
    {
        "flight_current_a", "land_speed_high_mps", "rtl_alt_m", "rtl_speed_mps",
        "rtl_alt_final_m", "rtl_loiter_s", "rtl_cone_slope", "rtl_climb_min_m",
    }
)  # fmt: skip


def airframe(flight: dict[str, Any] | None) -> tuple | None:
    """What identifies a vehicle's airframe for the fleet's shared draw: its autopilot's figures
    (speeds, accelerations, landing, BATT_CAPACITY) but the measured draw and its way home; None
    for a vehicle whose draw is known (our simulator reports its model) or that reports
    nothing."""
    if not flight or "hover_current_a" in flight:
        return None
    return tuple(sorted((k, v) for k, v in flight.items() if k not in _NOT_AIRFRAME))


def fleet_draws(flights: list[dict[str, Any] | None]) -> dict[tuple, list[float]]:
    """The draws measured in flight (``flight_current_a``) per airframe, over the fleet."""
    found: dict[tuple, list[float]] = {}
    for flight in flights:
        key = airframe(flight)
        draw = (flight or {}).get("flight_current_a")
        if key is not None and isinstance(draw, int | float) and draw > 0:
            found.setdefault(key, []).append(float(draw))
    return found


def with_fleet_draw(
    flight: dict[str, Any] | None, draws: dict[tuple, list[float]]
) -> tuple[dict[str, Any] | None, str | None]:
    """``flight`` with the draw its estimate uses, and a note when it is not its own: measured
    on other drones of its airframe (their mean), or, for an airframe nobody measured yet,
    :data:`CONSERVATIVE_DRAW_A` (or the highest draw the fleet measured, if higher)."""
    key = airframe(flight)
    if key is None or not flight or flight.get("flight_current_a"):
        return flight, None
    same = draws.get(key)
    if same:
        mean = sum(same) / len(same)
        note = f"draw {mean:.1f} A, measured on {len(same)} drone(s) of its airframe"
        return {**flight, "flight_current_a": mean}, note
    highest = max((d for ds in draws.values() for d in ds), default=0.0)
    assumed = max(CONSERVATIVE_DRAW_A, highest)
    note = (
        f"its airframe's draw is not measured yet: {assumed:.0f} A assumed (conservative)"
        " until it has flown"
    )
    return {**flight, "flight_current_a": assumed}, note


def drone_model(
    flight: dict[str, Any] | None,
    draws: dict[tuple, list[float]],
    *,
    reported_wind: dict[str, Any] | None = None,
    wind_mps: float | None = None,
    wind_from_deg: float = 0.0,
) -> VehicleModel:
    """The model one drone's estimates fly: its autopilot's figures (``Heartbeat.flight``) with
    the draw :func:`with_fleet_draw` gives it, in the mission's wind or its autopilot's. Without
    it an in-flight decision (early replacement, choosing a replacement) flew the dissertation
    quad's 18 A and 10 m/s: on ArduPilot SITL (about 30 A) the tired copter found it could not
    finish one more waypoint at 23 % and left with nobody on the way (issue 28, item 5)."""
    drawn, _ = with_fleet_draw(flight, draws)
    model, _ = vehicle_model(
        drawn, reported_wind=reported_wind, wind_mps=wind_mps, wind_from_deg=wind_from_deg
    )
    return model
