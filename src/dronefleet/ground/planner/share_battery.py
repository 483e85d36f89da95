"""Whether a drone's battery can fly its share: the share's estimate with its way home, a
handover in flight when it cannot and a drone could take over, and the hover a share that ends
in the air leaves (ground/planner/estimate/)."""

from __future__ import annotations

from typing import Any

from dronefleet.ground.planner.deconflict import Share
from dronefleet.ground.planner.ends import ends_on_the_ground
from dronefleet.ground.planner.estimate import Estimate, VehicleModel, can_finish, estimate
from dronefleet.ground.planner.fleet_view import DroneView
from dronefleet.ground.planner.mission_spec import MissionSpec
from dronefleet.ground.planner.service import PlannerError
from dronefleet.messaging.commands import Command


def hover_left(est: Estimate, model: VehicleModel, reserve_pct: float) -> str:
    """What a share that ends in the air leaves: minutes of hover before the reserve."""
    current_a = model.flight_current_a or model.hover_current_a
    left_mah = max(est.battery_end_pct - reserve_pct, 0.0) / 100 * model.capacity_mah
    minutes = left_mah / current_a * 3.6 / 60
    return (
        f"holds where its work ends: about {minutes:.1f} min of hover before the"
        f" {reserve_pct:g}% reserve, then it must be brought home"
    )


def home_from(share: Share) -> int:
    """Index (in the share's steps) of the first step of its way home: its end, or the last
    land/RTL of steps that end on the ground by themselves; past the end for a ``hold``."""
    steps = share.steps
    if share.end:
        return len(steps) - len(share.end)
    if ends_on_the_ground(steps):
        return max(
            i for i, s in enumerate(steps) if s.get("command") in (Command.LAND, Command.RTL)
        )
    return len(steps)


def can_fly(
    spec: MissionSpec,
    fleet: dict[str, DroneView],
    busy: set[str],
    chosen: list[DroneView],
    drone: DroneView,
    share: Share,
    reserve_pct: float,
) -> tuple[Estimate, bool, str]:
    """The estimate of ``share`` for ``drone``, in its wind and with its way home; refuses
    (PlannerError) a share its battery cannot finish when no drone could take it over. Run
    before the separation check too: a share thousands of kilometres long is refused here at
    once, not predicted second by second against the traffic."""
    est = estimate(
        share.steps,
        start=drone.position,
        home=drone.home,
        airborne=drone.airborne,
        battery_pct=drone.battery_pct,
        model=share.vehicle,  # its own autopilot's figures, in the wind
    )
    ok, why = can_finish(est, reserve_pct=reserve_pct, home_from=home_from(share))
    if not ok and not relief_exists(spec, fleet, busy, chosen, est):
        raise PlannerError(
            f"drone {drone.drone_id} cannot finish its share: {why}",
            check="battery",
            drone_id=drone.drone_id,
        )
    return est, ok, why


def relief_exists(spec: MissionSpec, fleet: dict, busy: set, chosen: list, est: Any) -> bool:
    """A share the battery cannot finish is still accepted when the planner will hand it over
    in flight (early replacement on) and an idle drone could fly all of it with the reserve."""
    if not (spec.options.replacement and spec.options.early_replacement):
        return False
    taken = busy | {d.drone_id for d in chosen}
    spare = [d for d in fleet.values() if d.idle and d.drone_id not in taken]
    return any(d.battery_pct - est.battery_used_pct >= 20.0 + 5.0 for d in spare)
