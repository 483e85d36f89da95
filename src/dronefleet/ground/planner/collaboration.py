"""Collaborative extension (seed 3.1.5, 5.4): an OUT_MEASURE alarm grows the area and shares it.

The new area is centred where the alarm happened and is 50% larger per joining drone (the seed's
rule), same shape and spacing (the extensibility parameters, generalised to any polygon). The
joining drones are the nearest idle ones with enough battery. The waypoints are split so that the
mission ends as early as possible — each drone's preparation, transit and work balanced — rather
than in equal counts (``strategy: seed`` keeps the seed's equal split for comparison). The unflown
part of the old area is superseded by the new one.
"""

from __future__ import annotations

import logging
from typing import Any

from dronefleet.geo.types import LLA
from dronefleet.ground.planner import allocation
from dronefleet.ground.planner.coverage import AreaSpec, plan_area, rebuild, seed_grid_rebuild
from dronefleet.ground.planner.deconflict import Share
from dronefleet.ground.planner.ends import end_steps
from dronefleet.ground.planner.fleet_view import DroneView, candidates
from dronefleet.ground.planner.legs import preparation
from dronefleet.ground.planner.models import Expansion, LatLon, Leg, LegState, MissionRecord
from dronefleet.ground.planner.ops import PlannerOps
from dronefleet.ground.planner.options import LegRole
from dronefleet.ground.planner.separation import SeparationConflict
from dronefleet.ground.planner.traffic import keep_apart
from dronefleet.ground.planner.units import units
from dronefleet.messaging.status import Alarm

log = logging.getLogger(__name__)


async def extend(planner: PlannerOps, record: MissionRecord, leg: Leg, alarm: Alarm) -> None:
    async with planner.lock:
        limit = record.options.max_expansions
        if record.area is None or len(record.expansions) >= limit or not leg.active:
            return
        pos = alarm.position
        centre = LLA(pos.lat, pos.lon, pos.alt_m)
        expansion = Expansion(
            drone_id=leg.drone_id,
            alarm_vehicle_s=alarm.vehicle_time_s,
            centre=LatLon(lat=centre.lat, lon=centre.lon),
        )
        record.expansions.append(expansion)  # claimed before any await: one extension per alarm
        try:
            fleet = await planner.fleet.drones()
        except Exception as exc:
            expansion.error = f"the Drone Identifier did not answer: {exc}"
            await planner.save(record)
            return
        wanted = record.options.collaborators
        joiners = candidates(
            fleet,
            centre,
            exclude=planner.busy_drones() | {leg.drone_id},
            min_battery_pct=planner.reserve_pct + 10,
        )[:wanted]
        me = next((d for d in fleet if d.drone_id == leg.drone_id), None)
        team: list[DroneView] = ([me] if me else []) + joiners
        if not team:
            expansion.error = "no drone available to extend the area"
            await planner.save(record)
            return
        strategy = record.options.strategy
        factor = 1.0 + 0.5 * len(joiners)
        slots = [
            allocation.DroneSlot(
                drone_id=d.drone_id,
                position=d.position,
                airborne=d.airborne or d.drone_id == leg.drone_id,
                battery_pct=d.battery_pct,
                home=d.home,
            )
            for d in team
        ]
        # The grown area's coverage and split are CPU work: the planning worker does them.
        new_spec, new_work, assignments, covered = await planner.worker.run(
            grown, record.area, centre, factor, strategy, slots
        )
        offset = len(record.work)
        record.work.extend(new_work)
        new_indices = list(range(offset, offset + len(new_work)))
        groups = [[i + offset for i in g] for g in units(new_work)]
        shares: dict[str, list[int]] = {}
        expansion.area_factor = factor
        expansion.joined = [d.drone_id for d in joiners]
        expansion.waypoints, expansion.area_m2 = covered["waypoints"], covered["area_m2"]
        expansion.assignments = {a.drone_id: len(a.waypoint_indices) for a in assignments}
        altitude = new_spec.altitude_m
        members = {a.drone_id for a in assignments if a.waypoint_indices}
        planned: list[Share] = []
        for offset_m, assignment in zip(
            allocation.altitude_offsets(len(assignments)), assignments, strict=False
        ):
            drone = next(d for d in team if d.drone_id == assignment.drone_id)
            if not assignment.waypoint_indices:
                continue
            indices = [i for w in assignment.waypoint_indices for i in groups[w]]
            prefix = preparation(drone, altitude + offset_m, strategy=strategy)
            if drone.drone_id == leg.drone_id:
                prefix = []  # already up there, at the alarm point
            work = [record.work[i] for i in indices]
            end = end_steps(record.options.end_action, [*prefix, *work])
            planned.append(
                Share(
                    drone.drone_id, prefix, work, end, drone.position, drone.home,
                    drone.airborne or drone.drone_id == leg.drone_id, drone.flight,
                )
            )  # fmt: skip
            shares[drone.drone_id] = indices
        try:  # the team kept apart from each other and from everyone else in the air
            placed = await keep_apart(planner, fleet, planned)
        except SeparationConflict as exc:
            del record.work[offset:]
            expansion.error = str(exc)
            await planner.save(record)
            log.warning("mission %s not extended: %s", record.mission_id, exc)
            return
        record.required = [i for i in record.required_indices() if i in record.done] + new_indices
        record.area = new_spec
        for old in record.active_legs():
            if old.drone_id not in members:  # its share of the old area is superseded
                await planner.stop_leg(old, state=LegState.REPLACED)
        for place in placed:
            for old in record.active_legs():
                if old.drone_id == place.drone_id:
                    old.state = LegState.REPLACED
            await planner.send_leg(
                record,
                Leg(
                    leg_id=planner.next_leg_id(record),
                    drone_id=place.drone_id,
                    role=LegRole.PRIMARY
                    if place.drone_id == leg.drone_id
                    else LegRole.COLLABORATOR,
                    prefix=place.prefix,
                    indices=shares[place.drone_id],
                    suffix=place.end,
                ),
            )
            if place.notes:
                log.info("mission %s: %s", record.mission_id, "; ".join(place.notes))
        await planner.save(record)
    planner.emit("expansion", mission_id=record.mission_id, **expansion.model_dump(mode="json"))
    log.info("mission %s extended: %s", record.mission_id, expansion)


def grown(
    area: AreaSpec,
    centre: LLA,
    factor: float,
    strategy: str,
    slots: list[allocation.DroneSlot],
) -> tuple[AreaSpec, list[dict[str, Any]], list[Any], dict[str, Any]]:
    """The area grown ``factor`` times around ``centre``, its steps, their split among ``slots``
    and its figures (runs in the planning worker: ground/planner/worker.py)."""
    spec = area
    if strategy == "seed":
        new_spec = seed_grid_rebuild(spec, centre, factor)
    else:  # exactly the area the rule asks for, lines inset half a spacing from the edges
        inset = AreaSpec.model_validate({**spec.model_dump(mode="json"), "grid": "inset"})
        new_spec = rebuild(inset, centre, factor)
    plan = plan_area(new_spec)
    split = allocation.seed_equal_split if strategy == "seed" else allocation.split_route
    covered = {"waypoints": len(plan.waypoints), "area_m2": round(plan.area_m2, 1)}
    return new_spec, plan.mission_steps(), split(plan, slots), covered
