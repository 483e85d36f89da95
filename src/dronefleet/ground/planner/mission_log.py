"""The mission log the planner writes when a mission ends (seed 4.2.4, Fig. 5.7, 5.16, 5.22).

One JSON document: for each drone, every step it flew (global index, command, vehicle time,
duration, position) and the path it flew; the handovers and extensions; the mission's timing.
The replay viewer reads it; ``GET /api/v1/missions/{id}/log`` serves it.
"""

from __future__ import annotations

from typing import Any

from dronefleet.ground.planner.models import MissionRecord
from dronefleet.messaging.commands import Command

LOG_FORMAT = "dronefleet-mission-log/1"


def build_log(record: MissionRecord) -> dict[str, Any]:
    drones: dict[str, dict[str, Any]] = {}
    for leg in record.legs:
        entry = drones.setdefault(
            leg.drone_id, {"drone_id": leg.drone_id, "legs": [], "steps": [], "path": []}
        )
        entry["legs"].append(
            {
                "leg_id": leg.leg_id,
                "role": leg.role.value,
                "state": leg.state.value,
                "indices": leg.indices,
                "prefix": [s.get("command") for s in leg.prefix],
                "started_vehicle_s": leg.started_vehicle_s,
                "ended_vehicle_s": leg.ended_vehicle_s,
                "error": leg.error,
            }
        )
        for report in leg.reports:
            entry["steps"].append(
                {
                    "leg_id": leg.leg_id,
                    "index": report.index,
                    "command": report.command,
                    "vehicle_time_s": report.vehicle_time_s,
                    "started_s": report.started_s,
                    "duration_s": report.duration_s,
                    "position": report.position,
                    **({"measured": report.measured} if report.measured else {}),
                }
            )
    for drone_id, points in record.paths.items():
        entry = drones.setdefault(
            drone_id, {"drone_id": drone_id, "legs": [], "steps": [], "path": []}
        )
        entry["path"] = [{"t": p[0], "lat": p[1], "lon": p[2], "alt": p[3]} for p in points]
    waypoint_steps = [
        i for i, s in enumerate(record.work) if s.get("command") == Command.WAIT_FOR_FLIGHT
    ]
    return {
        "format": LOG_FORMAT,
        "mission_id": record.mission_id,
        "name": record.name,
        "state": record.state.value,
        "created_at": record.created_at,
        "started_at": record.started_at,
        "ended_at": record.ended_at,
        "error": record.error,
        "steps_planned": len(record.work),
        "steps_done": len(record.done),
        "waypoints_planned": len(waypoint_steps),
        "waypoints_reached": sum(1 for i in waypoint_steps if i in record.done),
        "work": record.work,
        "area": record.area.model_dump(mode="json") if record.area else None,
        "done": {str(k): v for k, v in sorted(record.done.items())},
        "alarms": [a.model_dump(mode="json") for a in record.alarms],
        "handovers": [h.model_dump(mode="json") for h in record.handovers],
        "expansions": [e.model_dump(mode="json") for e in record.expansions],
        "drones": list(drones.values()),
    }
