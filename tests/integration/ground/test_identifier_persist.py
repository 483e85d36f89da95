"""The Drone Identifier saves a fleet's records a chunk at a time, and every one of them.

A whole fleet heard at once falls due for saving at once: dumping 1000 records in one go held
the ground's event loop 50 ms (bench/ground_capacity.py, py-spy), and a REST request waited
through it. They are saved :data:`~dronefleet.ground.identifier.PERSIST_CHUNK` at a time.
"""

from __future__ import annotations

import time

import pytest

from dronefleet.ground.fleet import DroneRecord
from dronefleet.ground.identifier import PERSIST_CHUNK, DroneIdentifier
from dronefleet.ground.state import StateStore
from dronefleet.messaging.status import Heartbeat

pytestmark = pytest.mark.integration


def beat(drone_id: str) -> Heartbeat:
    return Heartbeat(
        drone_id=drone_id, timestamp=time.time(), vehicle_time_s=1.0, interval_s=5.0,
        position={"lat": 40.63, "lon": -8.659, "alt_m": 10.0, "relative_alt_m": 0.0},
        battery={"remaining_pct": 90.0, "voltage_v": 16.0}, state="flying", mode="GUIDED",
    )  # fmt: skip


async def test_a_whole_fleet_is_saved_in_chunks_and_nothing_is_left_out(tmp_path):
    state = await StateStore(tmp_path / "g.db").open()
    saved: list[int] = []
    save = state.save_drones

    async def counting(records):
        saved.append(len(records))
        await save(records)

    state.save_drones = counting  # type: ignore[method-assign]
    identifier = DroneIdentifier("mqtt://127.0.0.1:1", state, client_id="id-persist")
    count = 2 * PERSIST_CHUNK + 7
    for i in range(count):
        drone_id = f"P_{i}"
        identifier.fleet[drone_id] = DroneRecord.first(beat(drone_id), time.time(), 0.0)
        identifier._dirty.add(drone_id)
    identifier._dirty.add("GONE_1")  # dirty, but no longer in the fleet: dropped, not kept
    try:
        await identifier._flush()
        assert saved == [PERSIST_CHUNK, PERSIST_CHUNK, 7]
        assert not identifier._dirty
        assert len(await state.load_drones()) == count
    finally:
        await state.close()
