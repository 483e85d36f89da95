"""A lost drone's remaining work is taken over (issue 13, must-show 2).

A drone stops being heard mid-mission (its broker link cut: no heartbeat, progress or telemetry
comes from it any more). The Drone Identifier declares it lost after three heartbeat
intervals; the planner replaces it from its last known position with the idle drone, which flies
exactly the steps the lost drone had not reported, and the mission completes with a whole log.
"""

from __future__ import annotations

import asyncio

import pytest

from dronefleet.experiments.harness import Harness
from dronefleet.geo.types import NED
from dronefleet.ground.planner.models import MissionState
from dronefleet.ground.planner.options import LegRole, MissionOptions
from dronefleet.ground.planner.units import remaining
from support.missions import fly_with_a_spare, small_field_steps

pytestmark = [pytest.mark.integration, pytest.mark.virtual_time]


async def _fly_and_lose(h: Harness, *, replacement: bool) -> tuple[str, set[int]]:
    options = MissionOptions(
        strategy="ours", collaboration=False, early_replacement=False, replacement=replacement
    )
    mission_id = await fly_with_a_spare(h, small_field_steps(), options, spare_at=NED(10, 10))
    while len(h.planner.missions[mission_id].done) < 12:
        await asyncio.sleep(0.05)
    for client in h.fleet.apps["QUAD_A"].clients.values():
        await client.stop()  # its link is cut mid-mission: nothing more is heard from it
    done_before = set(h.planner.missions[mission_id].done)
    return mission_id, done_before


async def test_a_lost_drones_unreported_steps_are_flown_by_another_and_none_twice():
    async with Harness(speedup=10) as h:
        mission_id, done_before = await _fly_and_lose(h, replacement=True)
        record = await h.until_ended(mission_id, timeout_s=240)
        for _ in range(100):  # the log is written just after the record turns terminal
            log = await h.planner.store.load_log(mission_id)
            if log is not None:
                break
            await asyncio.sleep(0.05)

    assert record.state is MissionState.COMPLETED, record.error
    first, *_ = record.legs
    taken = next(leg for leg in record.legs if leg.role is LegRole.REPLACEMENT)
    assert taken.drone_id == "QUAD_B"
    # Exactly the steps QUAD_A had not reported done when it fell silent (whole waypoint units:
    # a unit half done is flown again from its navigate step).
    assert taken.indices == remaining(record.work, first.indices, done_before)
    assert set(first.indices) - done_before <= set(taken.indices)  # every unreported step
    assert len(set(taken.indices) & done_before) <= 1  # at most a half-done unit's navigate
    handover = record.handovers[0]
    assert handover.from_drone == "QUAD_A" and "lost" in handover.reason
    # No step missing from the log, no waypoint reached twice.
    waypoints = [
        s["index"]
        for d in log["drones"]
        for s in d["steps"]
        if s["index"] is not None and log["work"][s["index"]]["command"] == "wait_for_flight"
    ]
    assert sorted(waypoints) == sorted(set(waypoints))
    assert log["waypoints_reached"] == log["waypoints_planned"] == 28
    assert log["steps_done"] == log["steps_planned"]
    # The lost drone is told to go home when it hears the ground again.
    recovery = next(leg for leg in record.legs if leg.role is LegRole.RECOVERY)
    assert recovery.drone_id == "QUAD_A" and recovery.prefix[0]["command"] == "rtl"


async def test_with_replacement_off_a_lost_drones_mission_is_stalled_with_the_reason():
    async with Harness(speedup=10) as h:
        mission_id, _ = await _fly_and_lose(h, replacement=False)
        for _ in range(400):
            record = h.planner.missions[mission_id]
            if record.state is MissionState.STALLED:
                break
            await asyncio.sleep(0.05)
    assert record.state is MissionState.STALLED
    assert record.error is not None and "QUAD_A lost" in record.error


async def test_a_stalled_mission_runs_again_when_its_drone_is_back_and_completes():
    """A drone flies on through a lost link; heard again, its reports close the mission."""
    async with Harness(speedup=10) as h:
        mission_id, _ = await _fly_and_lose(h, replacement=False)
        for _ in range(400):
            if h.planner.missions[mission_id].state is MissionState.STALLED:
                break
            await asyncio.sleep(0.05)
        assert h.planner.missions[mission_id].state is MissionState.STALLED
        for client in h.fleet.apps["QUAD_A"].clients.values():
            await client.start(timeout_s=10)  # the link is back
        record = await h.until_ended(mission_id, timeout_s=240)
    assert record.state is MissionState.COMPLETED, record.error
    assert len(record.done) == len(record.work) and not record.handovers
