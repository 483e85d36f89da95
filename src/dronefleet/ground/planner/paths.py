"""The flown paths a mission record keeps for its log and replay: one point per drone every
:data:`PATH_SAMPLE_S` vehicle seconds, from its telemetry and its progress reports."""

from __future__ import annotations

from typing import Any

from dronefleet.ground.planner.models import MissionRecord
from dronefleet.messaging.common import Position

PATH_SAMPLE_S = 1.0  # vehicle seconds between path points kept for the mission log


def position_of(fields: dict[str, Any]) -> Position | None:
    """The position in a telemetry message's fields, None when it has none (or a bad one)."""
    if not {"lat", "lon"} <= fields.keys():
        return None
    try:
        return Position(
            lat=fields["lat"],
            lon=fields["lon"],
            alt_m=fields.get("alt_m", 0.0),
            relative_alt_m=fields.get("relative_alt_m", 0.0),
        )
    except ValueError:
        return None


def add_point(
    record: MissionRecord, drone_id: str, t: float | None, position: Position | None
) -> bool:
    """Keep ``drone_id`` at ``position`` at vehicle time ``t`` in the record's paths, unless its
    last point is more recent than the sampling period; whether it was kept."""
    if position is None or t is None:
        return False
    path = record.paths.setdefault(drone_id, [])
    if path and t - path[-1][0] < PATH_SAMPLE_S:
        return False
    path.append([round(t, 2), position.lat, position.lon, round(position.relative_alt_m or 0.0, 2)])
    return True
