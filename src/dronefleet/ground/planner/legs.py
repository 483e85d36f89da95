"""Preparation before a drone's share of the work: arm, take off, go where the work resumes.

Two strategies: ``ours`` climbs while flying (navigate straight after take-off, the vehicle climbs
and flies at once) and ``seed`` does it the dissertation's way (arm, take off, wait until at
altitude, then fly). Both reach the same waypoints; ours is faster (docs/DESIGN.md §10).
"""

from __future__ import annotations

from typing import Any

from dronefleet.ground.planner.fleet_view import DroneView
from dronefleet.messaging.commands import Command


def preparation(
    drone: DroneView,
    altitude_m: float,
    *,
    strategy: str = "ours",
    go_to: tuple[float, float] | None = None,
    transit_offset_m: float = 0.0,
) -> list[dict[str, Any]]:
    """Steps that bring ``drone`` into the air (if needed) and, optionally, to ``go_to``."""
    steps: list[dict[str, Any]] = []
    if not drone.airborne:
        steps += [
            {"command": "arm"},
            {"command": "takeoff", "value": altitude_m + transit_offset_m},
        ]
        if strategy == "seed":
            steps.append({"command": "wait_for_flight"})
    if go_to is not None:
        lat, lon = go_to
        steps += [
            {
                "command": "navigate",
                "lat": lat,
                "lon": lon,
                "altitude_delta": altitude_m + transit_offset_m,
            },
            {"command": "wait_for_flight"},
        ]
    return steps


def mission_altitude(work: list[dict[str, Any]], default: float = 10.0) -> float:
    """The height the work is flown at: the first navigate's, or ``default``."""
    for step in work:
        if step.get("command") == Command.NAVIGATE and step.get("altitude_delta") is not None:
            return float(step["altitude_delta"])
        if step.get("command") == Command.TAKEOFF and step.get("value") is not None:
            return float(step["value"])
    return default
