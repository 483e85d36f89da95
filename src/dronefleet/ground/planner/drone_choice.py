"""Which drones fly a mission: the ones it names (each known, heard and idle), else the idle
drone nearest its first place (ground/planner/fleet_view.py)."""

from __future__ import annotations

from typing import Any

from dronefleet.errors import Conflict, NotFound
from dronefleet.geo.types import LLA
from dronefleet.ground.planner.fleet_view import DroneView, candidates
from dronefleet.ground.planner.mission_spec import MissionSpec
from dronefleet.messaging.commands import Command


def choose_drones(
    spec: MissionSpec, work: list[dict[str, Any]], fleet: dict[str, DroneView], busy: set[str]
) -> list[DroneView]:
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
