"""Each drone's latest telemetry as the Mission Planner reads it (``planner.latest``).

The planner is handed every telemetry message of the fleet (its own drones' as they come, the
other replicas' from their pictures: ground/inbox.py) and reads this only when it decides
something: a launch's settling, a lost drone's last position, an orphan in the traffic. So a
message is kept as it came, its vehicle time and its own field map (a validated message's, never
changed after), and the dict the planner reads, the fields with ``vehicle_time_s``, is made when
it is read. Copying every message's fields instead cost about a microsecond a message, 2 % of a
replica's CPU at 10,000 drones over 4 hosts (bench/replica_share.py, issue 27).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any


class LatestTelemetry(Mapping[str, dict[str, Any]]):
    """Drone id -> its latest telemetry fields, ``vehicle_time_s`` included."""

    def __init__(self) -> None:
        self._kept: dict[str, tuple[float, dict[str, float]]] = {}

    def keep(self, drone_id: str, vehicle_time_s: float, fields: dict[str, float]) -> None:
        self._kept[drone_id] = (vehicle_time_s, fields)

    def __getitem__(self, drone_id: str) -> dict[str, Any]:
        vehicle_time_s, fields = self._kept[drone_id]
        return {**fields, "vehicle_time_s": vehicle_time_s}

    def __contains__(self, drone_id: object) -> bool:
        return drone_id in self._kept

    def __iter__(self) -> Iterator[str]:
        return iter(self._kept)

    def __len__(self) -> int:
        return len(self._kept)
