"""Each drone's share of a mission: which drone flies which steps, with its preparation and
its end (ground/planner/ends.py), kept apart from each other and from the traffic
(ground/planner/deconflict/), inside its geofence, and with its estimate (the way home
included). A share its battery cannot finish is refused, or handed over in flight
(ground/planner/share_battery.py).
"""

from __future__ import annotations

from typing import Any

from dronefleet.ground.planner import allocation
from dronefleet.ground.planner.deconflict import Share, separate
from dronefleet.ground.planner.drone_choice import choose_drones
from dronefleet.ground.planner.ends import (
    end_steps,
    ends_on_the_ground,
    layered_return,
    return_layers,
)
from dronefleet.ground.planner.estimate import (
    VehicleModel,
    part,
    vehicle_model,
    with_fleet_draw,
)
from dronefleet.ground.planner.fleet_view import DroneView
from dronefleet.ground.planner.flown_by import flown_by
from dronefleet.ground.planner.geofence import FenceBreach, check_share
from dronefleet.ground.planner.legs import mission_altitude, preparation
from dronefleet.ground.planner.mission_spec import MissionSpec, self_prepared
from dronefleet.ground.planner.separation import SeparationConflict
from dronefleet.ground.planner.service import PlannerError
from dronefleet.ground.planner.share_battery import can_fly, home_from, hover_left
from dronefleet.ground.planner.step_order import check_order
from dronefleet.ground.planner.units import units
from dronefleet.messaging.commands import Command


def assign(
    spec: MissionSpec,
    work: list[dict[str, Any]],
    plan: Any,
    fleet: dict[str, DroneView],
    busy: set[str],
    reserve_pct: float,
    others: list[Share] | None = None,
    max_altitude_m: float | None = None,
    draws: dict[tuple, list[float]] | None = None,
) -> list[tuple[DroneView, list[dict[str, Any]], list[int], list[dict[str, Any]], dict[str, Any]]]:
    """Which drone flies which steps, with its preparation, its end (ground/planner/ends.py),
    kept apart from each other and from ``others`` (ground/planner/deconflict/), and its
    estimate (the way home included); refuses with reasons."""
    chosen = choose_drones(spec, work, fleet, busy)
    altitude = mission_altitude(work, spec.area.altitude_m if spec.area else 10.0)
    strategy = spec.options.strategy
    if len(chosen) == 1 or plan is None or spec.steps is not None:
        if len(chosen) > 1:
            raise PlannerError("a step list flies on one drone; give an area alone to share it")
        shares = [(chosen[0], list(range(len(work))))]
    else:
        groups = units(work)
        slots = [
            allocation.DroneSlot(d.drone_id, d.position, d.airborne, d.battery_pct, d.home)
            for d in chosen
        ]
        by_id = {d.drone_id: d for d in chosen}
        try:
            if strategy == "seed":
                assignments = allocation.seed_equal_split(plan, slots)
            else:  # each share keeps the battery its way home needs
                home = spec.options.end_action == "rtl"
                assignments = allocation.split_route(plan, slots, returns_home=home)
        except ValueError as exc:  # allocation's refusal: the fleet cannot fly it all
            raise PlannerError(f"the drones cannot share the area: {exc}") from exc
        shares = [
            (by_id[a.drone_id], [i for w in a.waypoint_indices for i in groups[w]])
            for a in assignments
            if a.waypoint_indices
        ]
    # A vehicle's first flight: the draw measured on its airframe's other drones (``draws``:
    # those kept in the ground's state, plan_mission), else a conservative one
    # (estimate.with_fleet_draw); the preview says which.
    flights = {d.drone_id: with_fleet_draw(d.flight, draws or {}) for d, _ in shares}
    models = {
        d.drone_id: vehicle_model(
            flights[d.drone_id][0], reported_wind=d.wind, wind_mps=spec.options.wind_mps,
            wind_from_deg=spec.options.wind_from_deg,
        )
        for d, _ in shares
    }  # fmt: skip
    fence = spec.options.geofence
    ceilings = [c for c in (max_altitude_m, fence.ceiling_m if fence else None) if c is not None]
    ceiling = min(ceilings) if ceilings else None
    # An autopilot flying the mission on board completes NAV_TAKEOFF before its first waypoint
    # (ArduPilot's AUTO): the preparation says so, as the seed's does, and the estimate follows.
    prepare = "seed" if spec.options.onboard else strategy
    prepared = []
    for drone, indices in shares:
        prefix = [] if self_prepared(work) else preparation(drone, altitude, strategy=prepare)
        steps = prefix + [work[i] for i in indices]
        prepared.append((drone, indices, prefix, end_steps(spec.options.end_action, steps)))
    ends = _return_layers(prepared, work, altitude, models, ceiling)
    planned: list[Share] = []
    for (drone, indices, prefix, _), end in zip(prepared, ends, strict=True):
        steps = prefix + [work[i] for i in indices]
        # Flown in this order from the drone's state now (ground/planner/step_order.py); a
        # refusal names the step by its index in the work list (the caller's step list).
        check_order(
            steps + end,
            airborne=drone.airborne,
            armed=drone.state == "armed",
            index_of=[None] * len(prefix) + list(indices) + [None] * len(end),
        )
        planned.append(
            Share(
                drone.drone_id, prefix, [work[i] for i in indices], end, drone.position,
                drone.home, drone.airborne, drone.flight, models[drone.drone_id][0],
            )
        )  # fmt: skip
    for share, (drone, _) in zip(planned, shares, strict=True):
        can_fly(spec, fleet, busy, chosen, drone, share, reserve_pct)
    mine = {d.drone_id for d, _ in shares}
    try:
        placed = separate(
            planned, [t for t in others or [] if t.drone_id not in mine], ceiling_m=ceiling
        )
    except SeparationConflict as exc:
        raise PlannerError(str(exc)) from exc
    result = []
    for share, (drone, indices), place in zip(planned, shares, placed, strict=True):
        prefix, end = place.prefix, place.end
        steps = prefix + [work[i] for i in indices] + end
        if spec.options.geofence is not None:
            try:
                check_share(
                    spec.options.geofence, drone.drone_id, drone.position, drone.home, steps,
                    returns_home=spec.options.end_action == "rtl",
                )  # fmt: skip
            except FenceBreach as exc:  # tagged: the pre-flight checklist shows it as its check
                raise PlannerError(str(exc), check="fence", drone_id=drone.drone_id) from exc
        sent = Share(
            share.drone_id, prefix, share.work, end, share.start, share.home, share.airborne,
            share.flight, share.model,
        )  # fmt: skip
        est, ok, why = can_fly(spec, fleet, busy, chosen, drone, sent, reserve_pct)
        est.notes.extend(place.notes)
        est.notes.append(models[drone.drone_id][1])
        if (draw_note := flights[drone.drone_id][1]) is not None:
            est.notes.append(draw_note)
        if not ok:  # never a battery left below the reserve without saying what happens
            est.notes.append(
                f"handed over in flight: {why}; an idle drone takes over the rest before the"
                f" reserve (early replacement)"
            )
        home_s, home_pct = part(est, home_from(sent))
        if not end and not ends_on_the_ground(steps):  # ``hold``: it stays up over its work
            est.notes.append(hover_left(est, share.vehicle, reserve_pct))
        who, why_companion = flown_by(spec, drone.drone_id, sent, indices)
        result.append(
            (
                drone,
                prefix,
                indices,
                end,
                {
                    "duration_s": round(est.duration_s, 1),
                    "battery_used_pct": round(est.battery_used_pct, 1),
                    "battery_end_pct": round(est.battery_end_pct, 1),
                    "return_s": round(home_s, 1),
                    "return_battery_pct": round(home_pct, 1),
                    "flown_by": who,
                    "companion_reason": why_companion,
                    "notes": list(est.notes),
                },
            )
        )
    return result


def _return_layers(
    prepared: list[tuple[DroneView, list[int], list[dict[str, Any]], list[dict[str, Any]]]],
    work: list[dict[str, Any]],
    altitude: float,
    models: dict[str, tuple[VehicleModel, str]],
    ceiling: float | None,
) -> list[list[dict[str, Any]]]:
    """Each share's end: when several go home (RTL), each on a return layer of its own
    (ground/planner/ends.py), below the ceiling; else as ``end_steps`` made it."""
    ends = [end for *_, end in prepared]
    home = [
        k for k, end in enumerate(ends) if [s["command"] for s in end] == ["rtl", "wait_for_flight"]
    ]
    if len(home) < 2:
        return ends
    base = max([altitude, *(models[prepared[k][0].drone_id][0].rtl_alt_m for k in home)])
    heights = return_layers(len(home), base)
    if ceiling is not None and heights[-1] > ceiling:  # lower the stack under the ceiling
        heights = [h - (heights[-1] - ceiling) for h in heights]
        if heights[0] < altitude:
            return ends  # no room for layers: deconflict/ keeps them apart another way
    for k, height in zip(home, heights, strict=True):
        drone, indices, _, _ = prepared[k]
        last = next(
            (
                (work[i]["lat"], work[i]["lon"])
                for i in reversed(indices)
                if work[i].get("command") == Command.NAVIGATE
            ),
            None,
        )
        ends[k] = layered_return(last, drone.home, height)
    return ends
