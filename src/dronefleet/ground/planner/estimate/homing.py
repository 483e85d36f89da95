"""The way home (``rtl``) as the vehicle flies it, stage by stage (:class:`Phase`): its
autopilot's own RTL (ArduPilot Copter's ModeRTL: climb above where it is to the return height,
fly home at RTL_SPEED, loiter RTL_LOIT_TIME, land at its land speeds) or, without one, the
companion computer's (drone/navigation.py)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from dronefleet.ground.planner.estimate.vehicle import VehicleModel

#: ArduPilot's RTL never climbs less than this (RTL_ALT_MIN, ArduCopter/config.h: 30 cm).
_RTL_ALT_MIN_M = 0.3
#: Where a waypoint of the autopilot's own counts as reached (its S-curve ends on it).
_ARRIVED_M = 0.1


@dataclass(frozen=True, slots=True)
class Phase:
    """One stage of a flight home: fly to (n, e, h) until within the tolerances (``go``), hover
    (``loiter``), or land (``land``)."""

    kind: str
    n: float = 0.0
    e: float = 0.0
    h: float = 0.0
    tol_h: float = _ARRIVED_M
    tol_v: float = _ARRIVED_M
    speed: float | None = None  # a slower cap than the model's (RTL_SPEED)
    least_s: float = 0.0  # the stage takes at least this long (wp_settle_s)


def rtl_path(
    model: VehicleModel, h: float, stop: tuple[float, float]
) -> tuple[list[Phase], str | None]:
    """The stages of the flight home of a vehicle in the air at height ``h`` that would stop at
    ``stop`` (north, east of home), and a note when it ends in the air."""
    m = model
    if not m.native_rtl:  # drone/navigation.py: home at max(h, RTL_ALT_M), climbing on
        height = max(h, m.rtl_alt_m)
        tol = m.horizontal_tolerance_m
        return [Phase("go", 0.0, 0.0, height, tol, tol), Phase("land")], None
    # ArduCopter ModeRTL::build_path / compute_return_target: the origin is the stopping
    # point; the return height is max(RTL_ALT, height + RTL_CLIMB_MIN), no higher than
    # distance * RTL_CONE_SLOPE near home, never below the height it is at.
    on, oe = stop
    least = max(_RTL_ALT_MIN_M, h + m.rtl_climb_min_m)
    height = max(m.rtl_alt_m, least)
    if m.rtl_cone_slope >= 0.5:  # RTL_MIN_CONE_SLOPE
        height = min(height, max(math.hypot(on, oe) * m.rtl_cone_slope, least))
    height = max(height, h)
    path = [
        Phase("go", on, oe, height, least_s=m.wp_settle_s),  # INITIAL_CLIMB
        Phase("go", 0.0, 0.0, height, speed=m.rtl_speed_mps),  # RETURN_HOME
        Phase("loiter", least_s=m.rtl_loiter_s),  # LOITER_AT_HOME
    ]
    if m.rtl_alt_final_m > 0:  # FINAL_DESCENT: it stops there, in the air
        path.append(Phase("go", 0.0, 0.0, m.rtl_alt_final_m))
        note = f"RTL_ALT_FINAL is {m.rtl_alt_final_m:g} m: the drone stays in the air over home"
        return path, note
    path.append(Phase("land"))  # LAND
    return path, None
