"""Every report a drone sends ends up in the mission's record (issue 26), also around its end, in
one process on virtual time.

- A mission does not settle while reports of one of its legs are missing and being asked for
  again: before, the ``completed`` report that showed the gap ended the mission, and the reports
  the refill brought a moment later were dropped (chaos seed 108).
- A mission that completed while one of its drones was lost on its way home stays completed with
  its end time, and what that drone reports once heard again (the steps it flew unheard, its way
  home) is kept in the record: before, those reports were dropped (chaos seed 133).
"""

from __future__ import annotations

import asyncio
import sqlite3

import pytest

from dronefleet.experiments.harness import Harness
from dronefleet.geo.types import NED
from dronefleet.ground.planner.models import LegRole, LegState, MissionState
from dronefleet.ground.planner.options import MissionOptions
from dronefleet.messaging.missions import MissionProgress, ProgressEvent
from support.missions import fly_with_a_spare, small_field_steps

from .test_takeover_once import OPTIONS, cut, mend, start_and_fly, until

pytestmark = [pytest.mark.integration, pytest.mark.virtual_time]

ALONE = MissionOptions(
    strategy="ours", collaboration=False, early_replacement=False, replacement=False
)


def sent_seqs(h: Harness, drone_id: str, leg_id: str) -> list[int]:
    """The report numbers ``drone_id`` gave ``leg_id`` (it keeps every report it sent)."""
    kept = h.fleet.apps[drone_id].mission_worker.reports.kept.get(leg_id, [])
    return sorted(p.seq for p in kept if p.seq is not None)


async def fly_alone(h: Harness):
    """QUAD_A flies the small field alone (QUAD_B idles): its mission, leg, the index of the
    leg's last step and QUAD_A's Mission Worker."""
    mission_id = await fly_with_a_spare(h, small_field_steps(), ALONE, spare_at=NED(10, 10))
    (leg,) = h.planner.missions[mission_id].legs
    last_step = len(leg.drone_steps(h.planner.missions[mission_id].work)) - 1
    return mission_id, leg, last_step, h.fleet.apps["QUAD_A"].mission_worker


async def test_a_mission_waits_for_its_missing_reports_before_it_ends() -> None:
    async with Harness(speedup=10) as h:
        mission_id, leg, last_step, worker = await fly_alone(h)
        post = worker.outbox.post
        dropped: list[int] = []

        def lose_the_last_step(topic_name: str, message) -> None:
            # The leg's last step report is lost on the way (its first sending); the next report
            # is the leg's ``completed``, which shows the gap. A replay goes through.
            if (
                isinstance(message, MissionProgress)
                and message.event is ProgressEvent.STEP
                and message.step_index == last_step
                and not dropped
            ):
                dropped.append(message.seq or 0)
                return
            post(topic_name, message)

        worker.outbox.post = lose_the_last_step
        record = await h.until_ended(mission_id, timeout_s=240)
        seqs_at_end = list(record.legs[0].seqs)
        drone_sent = sent_seqs(h, "QUAD_A", leg.leg_id)
    assert dropped, "the last step's report was never sent"
    assert record.state is MissionState.COMPLETED, record.error
    assert record.ended_at is not None
    # Every report the drone sent was in the record when the mission ended.
    assert seqs_at_end == drone_sent and dropped[0] in seqs_at_end


async def test_a_leg_that_ends_with_a_gap_while_its_drone_is_lost_waits_for_its_reports() -> None:
    """Chaos seed 108: every drone was declared lost while the ground's broker was down; when the
    link came back, each drone's backlog came in before its first heartbeat, and not in order (a
    leg's ``completed`` before the step reports of its middle). The mission was failed on the gap
    ("every leg ended with 6 steps not flown") a moment before those reports arrived: a drone
    declared lost was never waited for. Now a drone that sent a report of the leg within the
    hold is waited for, lost or not."""
    async with Harness(speedup=10) as h:
        mission_id, leg, last_step, worker = await fly_alone(h)
        post = worker.outbox.post
        dropped: list[int] = []

        def end_first_while_lost(topic_name: str, message) -> None:
            if not isinstance(message, MissionProgress):
                post(topic_name, message)
                return
            step = message.event is ProgressEvent.STEP and message.step_index == last_step
            if step and not dropped:  # held back: it comes with the replay the gap asks for
                dropped.append(message.seq or 0)
                return
            if message.event is ProgressEvent.COMPLETED:
                h.planner.lost.add("QUAD_A")  # as the Drone Identifier had said, the link down
            post(topic_name, message)

        worker.outbox.post = end_first_while_lost
        record = await h.until_ended(mission_id, timeout_s=240)
        seqs_at_end = list(record.legs[0].seqs)
        drone_sent = sent_seqs(h, "QUAD_A", leg.leg_id)
    assert dropped, "the last step's report was never held back"
    assert record.state is MissionState.COMPLETED, record.error
    assert seqs_at_end == drone_sent and dropped[0] in seqs_at_end


async def test_a_mission_completed_while_a_drone_was_lost_keeps_what_it_reports_when_back():
    async with Harness(speedup=10) as h:
        mission_id = await start_and_fly(h)
        await cut(h, "QUAD_A")  # lost; QUAD_B takes over and finishes the work
        record = await h.until_ended(mission_id, timeout_s=240)
        ended_at, state = record.ended_at, record.state
        first = record.legs[0]
        unheard = sent_seqs(h, "QUAD_A", first.leg_id)
        assert len(unheard) > len(first.seqs), "QUAD_A flew nothing unheard"
        await mend(h, "QUAD_A")  # heard again: its reports come in, it is sent home
        (going,) = [lg for lg in record.legs if lg.role is LegRole.RECOVERY]
        await until(lambda: going.state is LegState.COMPLETED, timeout_s=120)
        await until(lambda: first.seqs == sent_seqs(h, "QUAD_A", first.leg_id), timeout_s=60)
        await asyncio.sleep(0.5)
        stored = next(r for r in await h.planner.store.load_all() if r.mission_id == mission_id)
    assert state is MissionState.COMPLETED and ended_at is not None
    # Still completed, with the same end time; QUAD_A's reports and its way home recorded.
    assert record.state is MissionState.COMPLETED and record.ended_at == ended_at
    assert stored.legs[0].seqs == first.seqs and stored.ended_at == ended_at
    assert going.drone_id == "QUAD_A"
    assert OPTIONS.replacement


async def test_a_full_disk_as_the_leg_ends_does_not_leave_the_mission_running() -> None:
    """Chaos seed 320: the ground's disk was full as the last leg ended; the report's write
    failed, the handler stopped there, and the mission stayed ``running`` for ever, every step
    flown. Now the report is kept, the mission ends, and it is written once there is room."""
    async with Harness(speedup=10) as h:
        mission_id, _leg, _last_step, _worker = await fly_alone(h)
        store = h.planner.store
        save = store.save
        refused: list[str] = []

        async def full_disk(record) -> None:
            # Full from the leg's end on, for the first three writes of this mission.
            ended = not record.legs[0].active
            if record.mission_id == mission_id and ended and len(refused) < 3:
                refused.append(record.state.value)
                raise sqlite3.OperationalError("database or disk is full")
            await save(record)

        store.save = full_disk
        record = await h.until_ended(mission_id, timeout_s=240)
        assert refused, "the disk was never full when the leg ended"
        for _ in range(100):  # the flusher writes it within 2 s of there being room
            kept = {r.mission_id: r for r in await store.load_all()}[mission_id]
            if kept.state is MissionState.COMPLETED:
                break
            await asyncio.sleep(0.1)
    assert record.state is MissionState.COMPLETED, record.error
    assert record.ended_at is not None
    assert kept.state is MissionState.COMPLETED and kept.ended_at == record.ended_at
