"""Durable mission state (docs/DESIGN.md §7): every mission record and every mission log.

Kept in the ground state store's SQLite file, so restarting the planner mid-mission loses nothing:
the records are reloaded and tracking carries on.
"""

from __future__ import annotations

from typing import Any

import orjson

from dronefleet.clock import timestamp_s
from dronefleet.ground.planner.models import MissionRecord
from dronefleet.ground.state import StateStore

_SCHEMA = """
CREATE TABLE IF NOT EXISTS missions (
    mission_id TEXT PRIMARY KEY,
    state TEXT NOT NULL,
    record BLOB NOT NULL,
    updated_at REAL NOT NULL
);
CREATE TABLE IF NOT EXISTS mission_logs (
    mission_id TEXT PRIMARY KEY,
    log BLOB NOT NULL,
    written_at REAL NOT NULL
);
"""


class MissionStore:
    def __init__(self, state: StateStore) -> None:
        self.state = state

    async def open(self) -> MissionStore:
        await self.state.script(_SCHEMA)
        return self

    async def save(self, record: MissionRecord) -> None:
        blob = orjson.dumps(record.model_dump(mode="json"))
        await self.state.write(
            (
                "INSERT INTO missions (mission_id, state, record, updated_at) VALUES (?, ?, ?, ?) "
                "ON CONFLICT(mission_id) DO UPDATE SET state=excluded.state, "
                "record=excluded.record, updated_at=excluded.updated_at",
                (record.mission_id, record.state.value, blob, timestamp_s()),
            )
        )

    async def load_all(self) -> list[MissionRecord]:
        rows = await self.state.rows("SELECT record FROM missions ORDER BY updated_at")
        return [MissionRecord.model_validate(orjson.loads(r[0])) for r in rows]

    async def save_log(self, mission_id: str, log: dict[str, Any]) -> None:
        blob = orjson.dumps(log)
        await self.state.write(
            (
                "INSERT INTO mission_logs (mission_id, log, written_at) VALUES (?, ?, ?) "
                "ON CONFLICT(mission_id) DO UPDATE SET log=excluded.log, "
                "written_at=excluded.written_at",
                (mission_id, blob, timestamp_s()),
            )
        )

    async def load_log(self, mission_id: str) -> dict[str, Any] | None:
        rows = await self.state.rows(
            "SELECT log FROM mission_logs WHERE mission_id = ?", (mission_id,)
        )
        return orjson.loads(rows[0][0]) if rows else None
