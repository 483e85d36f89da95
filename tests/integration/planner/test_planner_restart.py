"""Nothing acknowledged is lost: the ground services die in the middle of a replacement.

Issue 4, must-show 4. The planner's broker session is persistent, so the progress the drones
publish while it is down is delivered when it comes back; its mission records are in SQLite.
The mission still completes and its log is whole.
"""

from __future__ import annotations

import asyncio

import pytest

from dronefleet.experiments.harness import ORIGIN, Harness
from dronefleet.geo.types import NED
from dronefleet.ground.planner.launch import MissionOptions
from support.missions import fly_with_a_spare, restart_ground_after, small_field_steps

pytestmark = [pytest.mark.integration, pytest.mark.virtual_time]

#: Replaced on its CRITICAL alarm only (no early replacement), the seed's way.
ON_ALARM = MissionOptions(strategy="seed", collaboration=False, early_replacement=False)


async def test_ground_restart_during_a_replacement_loses_nothing():
    async with Harness(speedup=10) as h:
        mission_id = await fly_with_a_spare(
            h, small_field_steps("CRITICAL"), ON_ALARM, spare_at=NED(77, 70), hovering_m=10
        )

        # Wait for the handover, then kill the ground while QUAD_B is on its way.
        while not h.planner.missions[mission_id].handovers:
            await asyncio.sleep(0.05)
        while not any(leg.role == "replacement" for leg in h.planner.missions[mission_id].legs):
            await asyncio.sleep(0.05)
        await h.stop_ground()
        down_at = h.clock.now()
        await h.clock.sleep(15)  # QUAD_B flies on and reports progress nobody is listening to
        await h.start_ground()
        assert h.clock.now() - down_at >= 15 - 1e-6  # vehicle seconds, float sums of 0.05 s
        record = await h.until_ended(mission_id, timeout_s=120)
        # The record turns terminal in memory just before its log is written: wait for the log.
        for _ in range(100):
            log = await h.planner.store.load_log(mission_id)
            if log is not None:
                break
            await asyncio.sleep(0.05)

    assert record.state.value == "completed", record.error
    assert log["waypoints_reached"] == log["waypoints_planned"] == 28
    drones = {d["drone_id"]: d for d in log["drones"]}
    assert set(drones) == {"QUAD_A", "QUAD_B"}
    flown = [
        s
        for d in log["drones"]
        for s in d["steps"]
        if s["index"] is not None and log["work"][s["index"]]["command"] == "wait_for_flight"
    ]
    assert sorted(s["index"] for s in flown) == sorted(set(s["index"] for s in flown))
    assert len(flown) == 28
    assert log["handovers"][0]["to_drone"] == "QUAD_B"
    # Progress published while the planner was down reached it after the restart.
    assert any(s["vehicle_time_s"] > down_at for s in drones["QUAD_B"]["steps"])
    assert ORIGIN.lat < max(p["lat"] for p in drones["QUAD_B"]["path"])


async def test_a_replacement_decided_just_before_the_ground_died_is_finished_after_it(monkeypatch):
    """The handover is written (the failing drone sent down) and the ground dies before choosing
    who takes over: the restarted planner finishes the handover (issue 13)."""
    from dronefleet.ground.planner import replacement

    decided = asyncio.Event()

    async def dies_here(*_args, **_kwargs):
        decided.set()
        await asyncio.Event().wait()  # the ground is killed here

    monkeypatch.setattr(replacement, "_hand_over", dies_here)

    async def undone() -> None:
        monkeypatch.undo()

    async with Harness(speedup=10) as h:
        record = await restart_ground_after(
            h, ON_ALARM, decided, while_down=undone, wait_s=60, ended_s=120
        )

    assert record.state.value == "completed", record.error
    assert len(record.handovers) == 1 and record.handovers[0].to_drone == "QUAD_B"
    reached = {
        r.index
        for leg in record.legs
        for r in leg.reports
        if r.index is not None and record.work[r.index]["command"] == "wait_for_flight"
    }
    assert len(reached) == 28
