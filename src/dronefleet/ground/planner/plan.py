"""Planning a mission for the fleet as it is now: its work steps, the coverage figures a preview
shows, and each drone's share (ground/planner/shares.py). The CPU part runs in the planning
worker (ground/planner/worker.py), off the event loop and within its budget.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from dronefleet.ground.planner import airframe_draws
from dronefleet.ground.planner.deconflict import Share
from dronefleet.ground.planner.estimate import fleet_draws
from dronefleet.ground.planner.fleet_view import DroneView
from dronefleet.ground.planner.geofence import FenceBreach, check_rally
from dronefleet.ground.planner.mission_spec import MissionSpec, check_altitudes, work_of
from dronefleet.ground.planner.service import MissionPlanner, PlannerError
from dronefleet.ground.planner.shares import assign
from dronefleet.ground.planner.traffic import traffic
from dronefleet.messaging.commands import Command


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
    draws: dict[tuple, list[float]] | None = None,
) -> Planned:
    """The whole CPU part of planning: coverage, split, separation from ``others`` (the drones
    already flying: ground/planner/traffic.py), estimates (runs in a worker process)."""
    work, plan = work_of(spec)
    check_altitudes(work, max_altitude_m)
    try:
        check_rally(spec.options.geofence, spec.options.rally_points)
    except FenceBreach as exc:
        raise PlannerError(str(exc)) from exc
    if draws is None:  # none kept: the fleet's measured now
        draws = fleet_draws([d.flight for d in fleet.values()])
    shares = assign(spec, work, plan, fleet, busy, reserve_pct, others or [], max_altitude_m, draws)
    coverage = {
        # A step list's route is its navigate steps (issue 29: a preview drew none).
        "waypoints": [{"lat": p.lat, "lon": p.lon} for p in plan.waypoints]
        if plan
        else route_of(work),
        "area_m2": round(plan.area_m2, 1) if plan else None,
        "angle_deg": plan.angle_deg if plan and plan.pattern == "swaths" else None,
        "pattern": plan.pattern if plan else None,
        "spacing_m": getattr(plan, "spacing_m", None),
        # What the coverage target left uncovered (issue 30): how much and where.
        "uncovered_m2": round(plan.uncovered_m2, 1) if plan else None,
        "uncovered": [[list(p) for p in ring] for ring in plan.uncovered_rings] if plan else [],
    }
    return Planned(
        work, coverage, [(d.drone_id, pre, idx, end, est) for d, pre, idx, end, est in shares]
    )


def route_of(work: list[dict[str, Any]]) -> list[dict[str, float]]:
    """The points a step list flies to, in order: its ``navigate`` steps (the moves relative to
    where the drone is, changeN and changeE, have no place of their own before it flies)."""
    return [
        {"lat": float(s["lat"]), "lon": float(s["lon"])}
        for s in work
        if s.get("command") == Command.NAVIGATE
    ]


async def planned(
    planner: MissionPlanner, spec: MissionSpec, records: list[dict[str, Any]] | None = None
) -> Planned:
    """Plan ``spec`` for the fleet as it is now (``records``: the Drone Identifier's, when the
    caller has them), off the event loop and within the budget."""
    if records is None:
        records = await planner.fleet.records()
    views = (DroneView.from_public(d) for d in records)
    fleet = {d.drone_id: d for d in views if d is not None}
    others = traffic(
        planner.missions.values(), fleet.values(), exclude=set(), latest=planner.latest
    )
    # The draws measured per airframe, kept in the ground's state (airframe_draws.py).
    draws = await airframe_draws.learn(planner.store.state, fleet.values())
    return await planner.worker.run(
        plan_mission, spec, fleet, planner.busy_drones(), planner.reserve_pct,
        planner.max_altitude_m, others, draws,
    )  # fmt: skip
