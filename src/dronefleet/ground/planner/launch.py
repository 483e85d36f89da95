"""Creating, checking, previewing and starting missions (REST: ``/api/v1/missions``).

A mission is given as steps (the seed's commands) or as an area (coverage). Before it is accepted
it is checked: no step above the altitude limit, every drone's share inside its geofence
(ground/planner/geofence.py), and every drone's battery must finish its share with the reserve
left (energy estimated from the vehicle model). A refused mission changes nothing.
"""

from __future__ import annotations

import secrets
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from dronefleet.errors import Conflict, NotFound
from dronefleet.geo.types import LLA
from dronefleet.ground.planner import allocation
from dronefleet.ground.planner.bounds import AreaRequest
from dronefleet.ground.planner.coverage import AreaSpec, plan_area
from dronefleet.ground.planner.ends import end_steps
from dronefleet.ground.planner.estimate import VehicleModel, can_finish, estimate
from dronefleet.ground.planner.fleet_view import DroneView, candidates
from dronefleet.ground.planner.geofence import FenceBreach, check_share
from dronefleet.ground.planner.legs import mission_altitude, preparation
from dronefleet.ground.planner.models import Leg, MissionRecord, MissionState
from dronefleet.ground.planner.options import MissionOptions, RecordOptions, Strategy
from dronefleet.ground.planner.service import MissionPlanner, PlannerError
from dronefleet.ground.planner.units import units
from dronefleet.messaging.codec import MessageError
from dronefleet.messaging.commands import Command, parse_step
from dronefleet.messaging.common import reason

if TYPE_CHECKING:
    # Code may give any AreaSpec; MissionSpec re-checks it against the request bounds.
    AreaField = AreaSpec | None
else:
    AreaField = AreaRequest | None  # what a request is validated (and documented) as


class MissionSpec(BaseModel):
    """What a person (or the web planner) asks for."""

    model_config = ConfigDict(extra="forbid")

    name: str = Field(default="", max_length=200)
    mission_id: str | None = Field(default=None, pattern=r"^[A-Za-z0-9_\-]{1,64}$")
    drones: list[str] = Field(default_factory=list, max_length=50)
    steps: list[dict[str, Any]] | None = Field(default=None, max_length=10_000)
    area: AreaField = None
    options: MissionOptions = Field(default_factory=MissionOptions)

    @field_validator("area", mode="before")
    @classmethod
    def _bounded(cls, value: object) -> object:
        """An AreaSpec built in code is checked against the request bounds too."""
        if isinstance(value, AreaSpec) and not isinstance(value, AreaRequest):
            return value.model_dump()
        return value


def _plan(area: AreaSpec) -> Any:
    """The coverage plan of ``area``; the coverage planner's refusals (ValueError: a polygon that
    is not simple or has no area, a hole outside it, too many waypoints...) are the caller's
    input that cannot be planned, so a 422 with the planner's reason."""
    try:
        return plan_area(area)
    except ValueError as exc:
        raise PlannerError(f"area: {exc}") from exc


def work_of(spec: MissionSpec) -> tuple[list[dict[str, Any]], Any]:
    """The work steps (validated) and the coverage plan (for areas).

    An area alone gives its generated steps; steps alone are flown as given; both together fly
    the given steps (an edited waypoint list) and keep the area for a collaborative extension.
    """
    if spec.steps is None and spec.area is None:
        raise PlannerError("give 'steps', 'area', or both")
    plan = _plan(spec.area) if spec.area is not None else None
    if spec.steps is None:
        assert plan is not None  # an area was given
        return plan.mission_steps(), plan
    steps = []
    for i, step in enumerate(spec.steps):
        try:
            steps.append(parse_step(step).model_dump(mode="json", exclude_none=True))
        except MessageError as exc:
            raise PlannerError(f"step {i}: {exc}") from exc
    if not steps:
        raise PlannerError("a mission needs at least one step")
    return steps, plan


def check_altitudes(work: list[dict[str, Any]], limit_m: float) -> None:
    for i, step in enumerate(work):
        height = step.get("altitude_delta") if step.get("command") == Command.NAVIGATE else None
        if step.get("command") == Command.TAKEOFF:
            height = step.get("value")
        if height is not None and height > limit_m:
            raise PlannerError(
                f"step {i} ({step['command']}) goes to {height:g} m, above the {limit_m:g} m limit"
            )


def self_prepared(work: list[dict[str, Any]]) -> bool:
    """A step list that arms and takes off by itself needs no preparation prefix."""
    return any(s.get("command") in (Command.ARM, Command.TAKEOFF) for s in work)


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
) -> Planned:
    """The whole CPU part of planning: coverage, split, estimates (runs in a worker process)."""
    work, plan = work_of(spec)
    check_altitudes(work, max_altitude_m)
    shares = assign(spec, work, plan, fleet, busy, reserve_pct)
    coverage = {
        "waypoints": [{"lat": p.lat, "lon": p.lon} for p in plan.waypoints] if plan else [],
        "area_m2": round(plan.area_m2, 1) if plan else None,
        "angle_deg": getattr(plan, "angle_deg", None),
        "spacing_m": getattr(plan, "spacing_m", None),
    }
    return Planned(
        work, coverage, [(d.drone_id, pre, idx, end, est) for d, pre, idx, end, est in shares]
    )


async def planned(planner: MissionPlanner, spec: MissionSpec) -> Planned:
    """Plan ``spec`` for the fleet as it is now, off the event loop and within the budget."""
    fleet = {d.drone_id: d for d in await planner.fleet.drones()}
    return await planner.worker.run(
        plan_mission, spec, fleet, planner.busy_drones(), planner.reserve_pct,
        planner.max_altitude_m,
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
) -> list[tuple[DroneView, list[dict[str, Any]], list[int], list[dict[str, Any]], dict[str, Any]]]:
    """Which drone flies which steps, with its preparation, its end (ground/planner/ends.py) and
    its estimate (the way home included); refuses with reasons."""
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
    result = []
    for drone, indices in shares:
        prefix = [] if self_prepared(work) else preparation(drone, altitude, strategy=prepare)
        steps = prefix + [work[i] for i in indices]
        end = end_steps(spec.options.end_action, steps)
        steps += end
        if spec.options.geofence is not None:
            try:
                check_share(
                    spec.options.geofence, drone.drone_id, drone.position, drone.home, steps,
                    returns_home=spec.options.end_action == "rtl",
                )  # fmt: skip
            except FenceBreach as exc:
                raise PlannerError(str(exc)) from exc
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
            raise PlannerError(f"drone {drone.drone_id} cannot finish its share: {why}")
        if not ok:
            est.notes.append(f"handed over in flight: {why}")
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
        "drones": [
            {"drone_id": drone_id, "steps": len(prefix) + len(idx) + len(end), **est}
            for drone_id, prefix, idx, end, est in done.shares
        ],
    }


async def create(
    planner: MissionPlanner, spec: MissionSpec, *, start: bool = False
) -> MissionRecord:
    done = await planned(planner, spec)
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


async def start(planner: MissionPlanner, mission_id: str) -> MissionRecord:
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
    done = await planned(planner, spec)
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
