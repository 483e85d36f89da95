"""Creating, checking, previewing and starting missions (REST: ``/api/v1/missions``).

A mission is given as steps (the seed's commands) or as an area (coverage). Before it is accepted
it is checked: no step above the altitude limit, every drone's share inside its geofence
(ground/planner/geofence.py), and every drone's battery must finish its share with the reserve
left (energy estimated from the vehicle model). A refused mission changes nothing.
"""

from __future__ import annotations

import secrets
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any

from pydantic import ValidationError

from dronefleet.errors import Conflict, NotFound
from dronefleet.geo.types import LLA
from dronefleet.ground.planner import allocation
from dronefleet.ground.planner.coverage import AreaSpec
from dronefleet.ground.planner.deconflict import Share, separate
from dronefleet.ground.planner.ends import end_steps
from dronefleet.ground.planner.estimate import VehicleModel, can_finish, estimate
from dronefleet.ground.planner.fleet_view import DroneView, candidates
from dronefleet.ground.planner.geofence import FenceBreach, check_rally, check_share
from dronefleet.ground.planner.legs import mission_altitude, preparation
from dronefleet.ground.planner.mission_spec import (
    MissionSpec,
    check_altitudes,
    self_prepared,
    work_of,
)
from dronefleet.ground.planner.models import Leg, MissionRecord, MissionState
from dronefleet.ground.planner.options import MissionOptions, RecordOptions, Strategy
from dronefleet.ground.planner.separation import SeparationConflict
from dronefleet.ground.planner.service import MissionPlanner, PlannerError
from dronefleet.ground.planner.step_order import check_order
from dronefleet.ground.planner.traffic import traffic
from dronefleet.ground.planner.units import units
from dronefleet.messaging.commands import Command
from dronefleet.messaging.common import reason


@dataclass(frozen=True)
class Planned:
    """What planning a mission gives (computed in the planning worker, ground/planner/worker.py):
    its work steps, the coverage figures a preview shows, and each drone's share."""

    work: list[dict[str, Any]]
    coverage: dict[str, Any]
    # (drone, preparation, work indices, end steps, estimate)
    shares: list[tuple[str, list[dict[str, Any]], list[int], list[dict[str, Any]], dict[str, Any]]]


def plan_mission(
    spec: MissionSpec,
    fleet: dict[str, DroneView],
    busy: set[str],
    reserve_pct: float,
    max_altitude_m: float,
    others: list[Share] | None = None,
) -> Planned:
    """The whole CPU part of planning: coverage, split, separation from ``others`` (the drones
    already flying: ground/planner/traffic.py), estimates (runs in a worker process)."""
    work, plan = work_of(spec)
    check_altitudes(work, max_altitude_m)
    try:
        check_rally(spec.options.geofence, spec.options.rally_points)
    except FenceBreach as exc:
        raise PlannerError(str(exc)) from exc
    shares = assign(spec, work, plan, fleet, busy, reserve_pct, others or [], max_altitude_m)
    coverage = {
        "waypoints": [{"lat": p.lat, "lon": p.lon} for p in plan.waypoints] if plan else [],
        "area_m2": round(plan.area_m2, 1) if plan else None,
        "angle_deg": getattr(plan, "angle_deg", None),
        "spacing_m": getattr(plan, "spacing_m", None),
    }
    return Planned(
        work, coverage, [(d.drone_id, pre, idx, end, est) for d, pre, idx, end, est in shares]
    )


async def planned(
    planner: MissionPlanner, spec: MissionSpec, records: list[dict[str, Any]] | None = None
) -> Planned:
    """Plan ``spec`` for the fleet as it is now (``records``: the Drone Identifier's, when the
    caller has them), off the event loop and within the budget."""
    if records is None:
        records = await planner.fleet.records()
    views = (DroneView.from_public(d) for d in records)
    fleet = {d.drone_id: d for d in views if d is not None}
    others = traffic(planner.missions.values(), fleet.values(), exclude=set())
    return await planner.worker.run(
        plan_mission, spec, fleet, planner.busy_drones(), planner.reserve_pct,
        planner.max_altitude_m, others,
    )  # fmt: skip


def _chosen(spec: MissionSpec, work: list[dict[str, Any]], fleet: dict[str, DroneView],
            busy: set[str]) -> list[DroneView]:  # fmt: skip
    chosen: list[DroneView] = []
    for drone_id in spec.drones:
        drone = fleet.get(drone_id)
        if drone is None:
            raise NotFound(f"drone {drone_id!r} is not known")
        if not drone.online:
            raise Conflict(f"drone {drone_id} is lost")
        if drone_id in busy or drone.mission_id is not None:
            raise Conflict(f"drone {drone_id} is busy with mission {drone.mission_id}")
        chosen.append(drone)
    if not chosen:
        first = next((s for s in work if s.get("command") == Command.NAVIGATE), None)
        near = LLA(first["lat"], first["lon"]) if first else None
        if near is None and fleet:
            near = next(iter(fleet.values())).position
        pool = candidates(list(fleet.values()), near, exclude=busy) if near else []
        if not pool:
            raise Conflict("no idle drone is available")
        chosen = pool[:1]
    return chosen


def assign(
    spec: MissionSpec,
    work: list[dict[str, Any]],
    plan: Any,
    fleet: dict[str, DroneView],
    busy: set[str],
    reserve_pct: float,
    others: list[Share] | None = None,
    max_altitude_m: float | None = None,
) -> list[tuple[DroneView, list[dict[str, Any]], list[int], list[dict[str, Any]], dict[str, Any]]]:
    """Which drone flies which steps, with its preparation, its end (ground/planner/ends.py),
    kept apart from each other and from ``others`` (ground/planner/deconflict.py), and its
    estimate (the way home included); refuses with reasons."""
    chosen = _chosen(spec, work, fleet, busy)
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
        split = allocation.seed_equal_split if strategy == "seed" else allocation.split_route
        by_id = {d.drone_id: d for d in chosen}
        try:
            assignments = split(plan, slots)
        except ValueError as exc:  # allocation's refusal: the fleet cannot fly it all
            raise PlannerError(f"the drones cannot share the area: {exc}") from exc
        shares = [
            (by_id[a.drone_id], [i for w in a.waypoint_indices for i in groups[w]])
            for a in assignments
            if a.waypoint_indices
        ]
    # An autopilot flying the mission on board completes NAV_TAKEOFF before its first waypoint
    # (ArduPilot's AUTO): the preparation says so, as the seed's does, and the estimate follows.
    prepare = "seed" if spec.options.onboard else strategy
    planned: list[Share] = []
    for drone, indices in shares:
        prefix = [] if self_prepared(work) else preparation(drone, altitude, strategy=prepare)
        steps = prefix + [work[i] for i in indices]
        end = end_steps(spec.options.end_action, steps)
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
                drone.home, drone.airborne, drone.flight,
            )
        )  # fmt: skip
    for share, (drone, _) in zip(planned, shares, strict=True):
        _can_fly(
            spec, fleet, busy, chosen, drone, share.prefix + share.work + share.end, reserve_pct
        )
    fence = spec.options.geofence
    ceilings = [c for c in (max_altitude_m, fence.ceiling_m if fence else None) if c is not None]
    mine = {d.drone_id for d, _ in shares}
    try:
        placed = separate(
            planned,
            [t for t in others or [] if t.drone_id not in mine],
            ceiling_m=min(ceilings) if ceilings else None,
        )
    except SeparationConflict as exc:
        raise PlannerError(str(exc)) from exc
    result = []
    for (drone, indices), place in zip(shares, placed, strict=True):
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
        est, ok, why = _can_fly(spec, fleet, busy, chosen, drone, steps, reserve_pct)
        est.notes.extend(place.notes)
        if not ok:  # never a battery left below the reserve without saying what happens
            est.notes.append(
                f"handed over in flight: {why}; an idle drone takes over the rest before the"
                f" reserve (early replacement)"
            )
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
                    "notes": list(est.notes),
                },
            )
        )
    return result


def _can_fly(
    spec: MissionSpec,
    fleet: dict[str, DroneView],
    busy: set[str],
    chosen: list[DroneView],
    drone: DroneView,
    steps: list[dict[str, Any]],
    reserve_pct: float,
) -> tuple[Any, bool, str]:
    """The estimate of ``steps`` for ``drone``; refuses (PlannerError) a share its battery
    cannot finish when no drone could take it over. Run before the separation check too: a
    share thousands of kilometres long is refused here at once, not predicted second by second
    against the traffic."""
    est = estimate(
        steps,
        start=drone.position,
        home=drone.home,
        airborne=drone.airborne,
        battery_pct=drone.battery_pct,
        model=VehicleModel.of_vehicle(drone.flight),  # its own autopilot's figures
    )
    ok, why = can_finish(est, reserve_pct=reserve_pct)
    if not ok and not _relief_exists(spec, fleet, busy, chosen, est):
        raise PlannerError(
            f"drone {drone.drone_id} cannot finish its share: {why}",
            check="battery",
            drone_id=drone.drone_id,
        )
    return est, ok, why


def _relief_exists(spec: MissionSpec, fleet: dict, busy: set, chosen: list, est: Any) -> bool:
    """A share the battery cannot finish is still accepted when the planner will hand it over
    in flight (early replacement on) and an idle drone could fly all of it with the reserve."""
    if not (spec.options.replacement and spec.options.early_replacement):
        return False
    taken = busy | {d.drone_id for d in chosen}
    spare = [d for d in fleet.values() if d.idle and d.drone_id not in taken]
    return any(d.battery_pct - est.battery_used_pct >= 20.0 + 5.0 for d in spare)


async def preview(planner: MissionPlanner, spec: MissionSpec) -> dict[str, Any]:
    done = await planned(planner, spec)
    return {
        "steps": done.work,
        **done.coverage,
        "end_action": spec.options.end_action,
        "drones": [
            {"drone_id": drone_id, "steps": len(prefix) + len(idx) + len(end),
             "end": [s["command"] for s in end], **est}
            for drone_id, prefix, idx, end, est in done.shares
        ],
    }  # fmt: skip


#: Called with the request, its plan and the fleet's records before a mission flies; raises to
#: refuse it (the pre-flight checklist, ground/planner/preflight.py).
Gate = Callable[["MissionSpec", Planned, list[dict[str, Any]]], Awaitable[None]]


async def create(
    planner: MissionPlanner, spec: MissionSpec, *, start: bool = False, gate: Gate | None = None
) -> MissionRecord:
    records = await planner.fleet.records()
    done = await planned(planner, spec, records)
    if start and gate is not None:
        await gate(spec, done, records)
    record = MissionRecord(
        mission_id=spec.mission_id or f"M{secrets.token_hex(4)}",
        name=spec.name,
        drones=[drone_id for drone_id, *_ in done.shares],
        area=AreaSpec.model_validate(spec.area.model_dump()) if spec.area else None,
        work=done.work,
        options=RecordOptions(**spec.options.model_dump(), custom_steps=spec.steps is not None),
    )
    await planner.add(record)
    if start:
        await launch(planner, record, done.shares)
    return record


async def launch(planner: MissionPlanner, record: MissionRecord, shares: list[Any]) -> None:
    record.state = MissionState.RUNNING
    for drone_id, prefix, indices, end, _est in shares:
        leg = Leg(
            leg_id=planner.next_leg_id(record),
            drone_id=drone_id,
            prefix=prefix,
            indices=indices,
            suffix=end,
        )
        await planner.send_leg(record, leg)


async def start(
    planner: MissionPlanner, mission_id: str, *, gate: Gate | None = None
) -> MissionRecord:
    record = planner.get(mission_id)
    if record.state is not MissionState.PLANNED:
        raise Conflict(f"mission {mission_id} is {record.state.value}, not planned")
    try:
        spec = MissionSpec(
            drones=record.drones,
            steps=record.work if record.options.custom_steps else None,
            area=record.area,
            options=record.options.request(),
        )
    except ValidationError as exc:  # stored before the request bounds were tightened
        raise PlannerError(f"mission {mission_id} can no longer be planned: {reason(exc)}") from exc
    records = await planner.fleet.records()
    done = await planned(planner, spec, records)
    if gate is not None:
        await gate(spec, done, records)
    record.work = done.work
    await launch(planner, record, done.shares)
    return record


async def call_drone(
    planner: MissionPlanner,
    lat: float,
    lon: float,
    *,
    altitude_m: float = 10.0,
    strategy: Strategy = "ours",
) -> MissionRecord:
    """The seed's panic button (5.1): the nearest available drone comes and hovers above you."""
    target = LLA(lat, lon)
    fleet = await planner.fleet.drones()
    pool = candidates(
        fleet, target, exclude=planner.busy_drones(), min_battery_pct=planner.reserve_pct
    )
    if not pool:
        raise Conflict("no drone is available to come")
    spec = MissionSpec(
        name=f"call to {lat:.6f},{lon:.6f}",
        drones=[pool[0].drone_id],
        steps=[
            {
                "command": Command.NAVIGATE.value,
                "lat": lat,
                "lon": lon,
                "altitude_delta": altitude_m,
            },
            {"command": Command.WAIT_FOR_FLIGHT.value},
        ],
        # It comes to stay: a call ends hovering above the caller until an operator sends the
        # drone home (abort) or on.
        options=MissionOptions(strategy=strategy, collaboration=False, end_action="hold"),
    )
    return await create(planner, spec, start=True)
