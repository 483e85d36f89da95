"""The alarm log (ground/alarm_log.py): one row per alarm, bounded, open alarms kept longest."""

from __future__ import annotations

import pytest

from dronefleet.errors import Conflict, NotFound
from dronefleet.ground import alarm_log as module
from dronefleet.ground.alarm_log import AlarmFilter, AlarmLog
from dronefleet.ground.state import StateStore


def alarm(i: int, drone: str = "QUAD_1", level: str = "WARNING") -> dict:
    return {
        "drone_id": drone,
        "level": level,
        "message": f"alarm {i}",
        "vehicle_time_s": float(i),
        "timestamp": 1_700_000_000.0 + i,
    }


@pytest.fixture
async def log():
    state = await StateStore(":memory:").open()
    alarms = await AlarmLog(state, max_rows=10).start()
    yield alarms
    await alarms.stop()
    await state.close()


async def test_only_alarm_events_are_logged_once_each(log):
    log.on_planner_event("handover", {"drone_id": "QUAD_1"})
    log.on_planner_event("alarm", alarm(1))
    log.on_planner_event("alarm", alarm(1))  # the same, delivered again
    log.on_separation_alarm(alarm(1))  # the same words from the separation monitor: another
    await log.flush()
    entries = await log.query(AlarmFilter())
    assert [(e["source"], e["message"]) for e in entries] == [
        ("separation", "alarm 1"),
        ("drone", "alarm 1"),
    ]


async def test_past_the_bound_the_oldest_acknowledged_go_first(log):
    for i in range(10):
        log.add("drone", alarm(i))
    await log.flush()
    first = (await log.query(AlarmFilter(), limit=10))[-1]
    assert first["message"] == "alarm 0"
    open_one = (await log.query(AlarmFilter(), limit=10))[-2]  # alarm 1 stays open
    for entry in await log.query(AlarmFilter(), limit=10):
        if entry["id"] != open_one["id"]:
            await log.acknowledge(entry["id"], "op")
    for i in range(10, 13):
        log.add("drone", alarm(i))
    await log.flush()
    kept = {e["message"] for e in await log.query(AlarmFilter(), limit=100)}
    assert len(kept) <= 10
    assert "alarm 0" not in kept and "alarm 12" in kept
    with pytest.raises(NotFound, match="no alarm"):
        await log.get(first["id"])


async def test_an_alarm_is_acknowledged_once(log):
    log.add("drone", alarm(1, level="CRITICAL"))
    await log.flush()
    (entry,) = await log.query(AlarmFilter(level="CRITICAL"))
    acked = await log.acknowledge(entry["id"], "alice")
    assert (acked["acked_by"], acked["acknowledged"]) == ("alice", True)
    with pytest.raises(Conflict, match="already acknowledged by alice"):
        await log.acknowledge(entry["id"], "bob")
    assert (await log.get(entry["id"]))["acked_by"] == "alice"
    with pytest.raises(NotFound):
        await log.acknowledge(entry["id"] + 1, "bob")
    assert await log.count(AlarmFilter(acknowledged=False)) == 0


async def test_a_flood_is_dropped_and_counted_past_the_queue(log, monkeypatch):
    monkeypatch.setattr(module, "QUEUE_SIZE", 5)
    small = AlarmLog(log.state, max_rows=10)  # not started: nothing drains its queue
    for i in range(8):
        small.add("drone", alarm(i))
    assert small.dropped == 3
