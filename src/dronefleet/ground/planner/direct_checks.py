"""A direct move checked as a mission step is (issue 26): altitude, fence, battery there and home.

A direct ``navigate`` 50 km away was sent to the drone with no check at all, when a mission with
that step would have been refused by the planner. Before a direct ``navigate``, ``changeN`` or
``changeE`` goes out (ground/manager/drones.py), the same limits the planner applies to a
mission's share (ground/planner/shares.py) are applied to the one move:

* **altitude**: at most the planner's limit above home;
* **fence**: when the drone flies (or has paused) a mission with a geofence, the move stays
  inside it (ground/planner/geofence.py);
* **battery**: the planner's estimator (ground/planner/estimate/), with the drone's own
  autopilot figures, flies the move and then the way home (straight back at the RTL height, and
  down); the battery must end above the planner's reserve.

A refusal is an :class:`~dronefleet.errors.InvalidInput` (422) with the reason, audited like
every command. ``force`` does not override it: force takes the vehicle from a mission, it does
not make a flight the battery cannot finish possible (as the pre-flight checklist cannot
override the planner's own battery and fence refusals). A relative move is checked from where
the drone is (the drone adds it to its goal, at most a tolerance away once it has arrived).
"""

from __future__ import annotations

from typing import Any

from dronefleet.errors import InvalidInput
from dronefleet.geo.distance import distance_m
from dronefleet.geo.ned import lla_to_ned, ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.ground.planner.estimate import VehicleModel, can_finish, estimate
from dronefleet.ground.planner.fleet_view import DroneView
from dronefleet.ground.planner.geofence import check_share
from dronefleet.messaging.commands import Command

#: Commands checked here: the ones that send the vehicle somewhere else horizontally.
CHECKED = frozenset({Command.NAVIGATE, Command.CHANGE_N, Command.CHANGE_E})
#: Height of the way home in the estimate (ArduPilot's RTL_ALT default, drone/navigation.py).
RTL_ALT_M = 15.0


class MoveRefused(InvalidInput):
    """A direct move the planner would refuse as a mission step: the message says why."""


def target_of(request: Any, view: DroneView) -> LLA:
    """Where a direct move sends the drone (its height: the one asked, else where it flies)."""
    height = view.position.alt_m - view.home.alt_m
    if request.command == Command.NAVIGATE:
        if request.altitude_delta is not None:
            height = request.altitude_delta
        return LLA(request.lat, request.lon, view.home.alt_m + height)
    here = lla_to_ned(view.position, view.home)
    north = request.value if request.command == Command.CHANGE_N else 0.0
    east = request.value if request.command == Command.CHANGE_E else 0.0
    return ned_to_lla(NED(here.n + north, here.e + east, here.d), view.home)


def check_move(
    request: Any,
    record: dict[str, Any],
    *,
    max_altitude_m: float,
    reserve_pct: float,
    fence: Any = None,
) -> dict[str, Any] | None:
    """Raise :class:`MoveRefused` when the planner would refuse ``request`` (a direct move) for
    the drone the Drone Identifier describes in ``record``; else the estimate of the move and
    the way home (None when the ground knows too little of the drone to check it: the drone
    still checks what it can)."""
    if request.command not in CHECKED:
        return None
    view = DroneView.from_public(record)
    if view is None:
        return None
    drone_id, home = view.drone_id, view.home
    target = target_of(request, view)
    where = f"{target.lat:.6f}, {target.lon:.6f}"
    height = target.alt_m - home.alt_m
    if height > max_altitude_m:
        raise MoveRefused(
            f"{request.command} refused: {height:.0f} m above home is over the "
            f"{max_altitude_m:g} m limit"
        )
    step = {"command": Command.NAVIGATE.value, "lat": target.lat, "lon": target.lon,
            "altitude_delta": max(0.0, height)}  # fmt: skip
    if fence is not None:
        try:
            check_share(fence, drone_id, view.position, home, [step], returns_home=True)
        except InvalidInput as exc:
            raise MoveRefused(f"{request.command} refused: {exc}") from exc
    home_height = max(height, RTL_ALT_M)
    steps: list[dict[str, Any]] = [
        step,
        {"command": Command.WAIT_FOR_FLIGHT.value},
        {"command": Command.NAVIGATE.value, "lat": home.lat, "lon": home.lon,
         "altitude_delta": home_height},
        {"command": Command.WAIT_FOR_FLIGHT.value},
        {"command": Command.LAND.value},
        {"command": Command.WAIT_FOR_FLIGHT.value},
    ]  # fmt: skip
    est = estimate(
        steps,
        start=view.position,
        home=home,
        airborne=view.airborne,
        battery_pct=view.battery_pct,
        model=VehicleModel.of_vehicle(view.flight),
    )
    ok, why = can_finish(est, reserve_pct=reserve_pct)
    away_km = distance_m(home, target) / 1000.0
    if not ok:
        raise MoveRefused(
            f"{request.command} refused: {drone_id} could not fly to {where} "
            f"({away_km:.1f} km from home) and back: {why}"
        )
    return {
        "distance_from_home_m": round(away_km * 1000.0, 1),
        "duration_s": round(est.duration_s, 1),
        "battery_end_pct": round(est.battery_end_pct, 1),
    }


def fence_of(planner: Any, drone_id: str) -> Any:
    """The geofence of the mission ``drone_id`` flies or has paused (None: no mission, or one
    without a fence)."""
    for record in planner.missions.values():
        if not record.terminal and record.leg_of(drone_id) is not None:
            return record.options.geofence
    return None
