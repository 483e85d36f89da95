"""Every step flown by exactly one drone (issue 26, items 1 and 2), in one process on virtual time.

A drone's loss is the ground's view of it: a drone silent for less than its threshold, or heard
again before its replacement has started on its work, keeps its leg and nobody is sent home; a
drone truly gone is taken over once; with nobody to take over the mission stalls (not fails) and
runs again when the drone is heard. A ground stopped right after a CRITICAL alarm reached it and
started again on the same state finishes the handover once: every waypoint flown by one drone.

QUAD_A beats every vehicle second (experiments/harness.py), so it is lost after 3 s of silence
(3 intervals; the 2 s floor is lower) and its work is taken over after 3 s more.
"""

from __future__ import annotations

import asyncio
from collections import Counter
from typing import Any

import pytest

from dronefleet.experiments.harness import Harness
from dronefleet.geo.types import NED
from dronefleet.ground.planner import reconcile
from dronefleet.ground.planner.models import LegRole, MissionRecord, MissionState
from dronefleet.ground.planner.options import MissionOptions
from dronefleet.ground.planner.service import MissionPlanner
from dronefleet.messaging.local_bus import LocalBus
from support.missions import fly_with_a_spare, restart_ground_after, small_field_steps

pytestmark = [pytest.mark.integration, pytest.mark.virtual_time]

OPTIONS = MissionOptions(strategy="ours", collaboration=False, early_replacement=False)
#: Replaced on its CRITICAL alarm only (no early replacement), the seed's way.
ON_ALARM = MissionOptions(strategy="seed", collaboration=False, early_replacement=False)
WAYPOINTS = 28  # in small_field_steps()


def flown(record: MissionRecord) -> Counter[int]:
    """How many drones reported each waypoint (wait_for_flight step) of the mission."""
    return Counter(
        r.index
        for leg in record.legs
        for r in leg.reports
        if r.index is not None and record.work[r.index]["command"] == "wait_for_flight"
    )


def assert_each_waypoint_once(record: MissionRecord) -> None:
    counts = flown(record)
    assert len(counts) == WAYPOINTS, f"{WAYPOINTS - len(counts)} waypoints never flown"
    twice = {i: n for i, n in counts.items() if n > 1}
    assert not twice, f"waypoints flown more than once: {twice}"


async def cut(h: Harness, drone_id: str) -> None:
    """The drone's broker link is cut: nothing is heard from it, nothing reaches it."""
    for client in h.fleet.apps[drone_id].clients.values():
        await client.stop()


async def mend(h: Harness, drone_id: str) -> None:
    for client in h.fleet.apps[drone_id].clients.values():
        await client.start(timeout_s=10)


def same_credentials(monkeypatch: pytest.MonkeyPatch) -> None:
    """A ground started again keeps its broker credentials, as a real one does: its planner's
    persistent session (its client id is derived from them) is then resumed, and what it had not
    acknowledged is delivered again. (The harness gives each start a new password.)"""
    issued: dict[tuple[str, str], Any] = {}
    url_for = LocalBus.url_for

    def keeping(bus: LocalBus, name: str, role: Any) -> Any:
        if (bus.name, name) not in issued:
            issued[bus.name, name] = url_for(bus, name, role)
        return issued[bus.name, name]

    monkeypatch.setattr(LocalBus, "url_for", keeping)


async def until(predicate, timeout_s: float = 120.0) -> None:
    async with asyncio.timeout(timeout_s):
        while not predicate():
            await asyncio.sleep(0.05)


async def start_and_fly(h: Harness, done: int = 12, *, spare: bool = True, **options) -> str:
    opts = OPTIONS.model_copy(update=options)
    if spare:
        mission_id = await fly_with_a_spare(h, small_field_steps(), opts, spare_at=NED(10, 10))
    else:
        from dronefleet.ground.planner import launch

        await h.add_drone("QUAD_A", NED(0, 0))
        await h.wait_identified(["QUAD_A"])
        await h.settle()
        spec = launch.MissionSpec(name="alone", drones=["QUAD_A"], steps=small_field_steps(),
                                  options=opts)  # fmt: skip
        mission_id = (await launch.create(h.planner, spec, start=True)).mission_id
    await until(lambda: len(h.planner.missions[mission_id].done) >= done)
    return mission_id


async def test_a_drone_silent_for_less_than_its_threshold_keeps_its_leg():
    async with Harness(speedup=10) as h:
        mission_id = await start_and_fly(h)
        await cut(h, "QUAD_A")
        await h.clock.sleep(2.0)  # under the 3 s it takes to be lost
        await mend(h, "QUAD_A")
        record = await h.until_ended(mission_id, timeout_s=240)
        events = [e for e, _ in h.events]
    assert record.state is MissionState.COMPLETED, record.error
    assert not record.handovers and not record.takeovers_cancelled
    assert {leg.drone_id for leg in record.legs} == {"QUAD_A"}
    assert not [leg for leg in record.legs if leg.role is LegRole.RECOVERY]  # nobody sent home
    assert "handover" not in events
    assert_each_waypoint_once(record)


async def test_a_drone_heard_again_before_its_replacement_started_keeps_its_leg():
    """Lost after 3 s, taken over after 6 s (QUAD_B arms and climbs), heard again at 8 s: the
    takeover is called off, QUAD_B goes home, QUAD_A flies on; nobody flies a waypoint twice."""
    async with Harness(speedup=10) as h:
        mission_id = await start_and_fly(h)
        await cut(h, "QUAD_A")
        await until(lambda: h.planner.missions[mission_id].handovers, timeout_s=30)
        taken = h.planner.missions[mission_id].handovers[0]
        assert taken.to_drone == "QUAD_B" and not taken.committed
        assert not [lg for lg in h.planner.missions[mission_id].legs if lg.role is LegRole.RECOVERY]
        await h.clock.sleep(1.0)  # QUAD_B is on its way, not yet at QUAD_A's last place
        await mend(h, "QUAD_A")
        record = await h.until_ended(mission_id, timeout_s=240)
        await h.settle(20.0)
        b_vehicle = h.fleet.vehicle("QUAD_B")
        b_down = not b_vehicle.armed and not b_vehicle.in_air
    assert record.state is MissionState.COMPLETED, record.error
    assert not record.handovers
    (called_off,) = record.takeovers_cancelled
    assert called_off.from_drone == "QUAD_A" and called_off.to_drone == "QUAD_B"
    assert "heard again" in (called_off.cancelled or "")
    primary = record.legs[0]
    replacement = record.leg(called_off.to_leg or "")
    assert primary.drone_id == "QUAD_A" and primary.state.value == "completed"
    assert replacement is not None and not any(r.index is not None for r in replacement.reports)
    # QUAD_A was never told to go home; QUAD_B was, and is back on the ground.
    going = [lg for lg in record.legs if lg.role is LegRole.RECOVERY]
    assert [lg.drone_id for lg in going] == ["QUAD_B"]
    assert b_down
    assert_each_waypoint_once(record)


async def test_a_drone_truly_gone_is_taken_over_once_and_sent_home_once_its_replacement_started():
    async with Harness(speedup=10) as h:
        mission_id = await start_and_fly(h)
        await cut(h, "QUAD_A")
        record = await h.until_ended(mission_id, timeout_s=240)
    assert record.state is MissionState.COMPLETED, record.error
    (handover,) = record.handovers
    assert handover.from_drone == "QUAD_A" and handover.to_drone == "QUAD_B"
    assert handover.committed and "lost" in handover.reason
    assert [lg.drone_id for lg in record.legs if lg.role is LegRole.REPLACEMENT] == ["QUAD_B"]
    (going,) = [lg for lg in record.legs if lg.role is LegRole.RECOVERY]
    assert going.drone_id == "QUAD_A" and going.prefix[0]["command"] == "rtl"
    # Sent home only once QUAD_B had reached the place it resumes from.
    replacement = record.leg(handover.to_leg or "")
    assert replacement is not None
    assert record.legs.index(going) > record.legs.index(replacement)
    counts = flown(record)
    assert len(counts) == WAYPOINTS
    # At most the waypoint QUAD_A was flying to when it fell silent is flown twice (its report
    # never came); none other.
    assert sum(n - 1 for n in counts.values()) <= 1


async def test_with_nobody_free_a_lost_drones_mission_stalls_and_runs_again_when_it_is_back():
    async with Harness(speedup=10) as h:
        mission_id = await start_and_fly(h, spare=False)
        await cut(h, "QUAD_A")
        await until(
            lambda: h.planner.missions[mission_id].state is MissionState.STALLED, timeout_s=30
        )
        stalled = h.planner.missions[mission_id].model_copy(deep=True)
        await h.clock.sleep(15.0)  # a retry finds nobody either
        assert h.planner.missions[mission_id].state is MissionState.STALLED
        await mend(h, "QUAD_A")
        record = await h.until_ended(mission_id, timeout_s=240)
    assert stalled.error is not None and "QUAD_A lost" in stalled.error
    assert "nobody can take over" in stalled.error and stalled.ended_at is None
    assert record.state is MissionState.COMPLETED, record.error
    assert not record.handovers and {lg.drone_id for lg in record.legs} == {"QUAD_A"}
    assert not [lg for lg in record.legs if lg.role is LegRole.RECOVERY]
    assert_each_waypoint_once(record)


async def test_a_failed_mission_has_its_end_time():
    """A CRITICAL alarm and nobody to take over: the mission fails, and says when."""
    async with Harness(speedup=10) as h:
        from dronefleet.ground.planner import launch

        await h.add_drone("QUAD_A", NED(0, 0), hovering_m=10)
        await h.wait_identified(["QUAD_A"])
        await h.settle()
        spec = launch.MissionSpec(
            name="alone", drones=["QUAD_A"], steps=small_field_steps("CRITICAL"), options=ON_ALARM
        )
        mission_id = (await launch.create(h.planner, spec, start=True)).mission_id
        record = await h.until_ended(mission_id, timeout_s=240)
        stored = next(r for r in await h.planner.store.load_all() if r.mission_id == mission_id)
    assert record.state is MissionState.FAILED
    assert record.error is not None and "no idle drone can take over" in record.error
    assert record.ended_at is not None and stored.ended_at == record.ended_at


@pytest.mark.parametrize("turns", [0, 1, 2, 3, 5, 8, 13, 21, 34, 55])
async def test_a_ground_stopped_right_after_a_critical_alarm_hands_over_once(monkeypatch, turns):
    """The ground is stopped ``turns`` event-loop turns after the CRITICAL alarm reached the
    planner (before, while or after it was acted on), down 5 vehicle s while QUAD_A flies on,
    then started again on the same state: the handover happens once, every waypoint is flown by
    exactly one drone, and the mission completes."""
    received = asyncio.Event()
    on_alarm = MissionPlanner._on_alarm

    async def noticed(self, topic_name, payload):
        if b"CRITICAL" in payload:
            received.set()
        await on_alarm(self, topic_name, payload)

    monkeypatch.setattr(MissionPlanner, "_on_alarm", noticed)
    same_credentials(monkeypatch)
    async with Harness(speedup=10) as h:
        record = await restart_ground_after(
            h, ON_ALARM, received, turns=turns, while_down=lambda: h.clock.sleep(5.0)
        )
    assert record.state is MissionState.COMPLETED, record.error
    (handover,) = record.handovers
    assert handover.from_drone == "QUAD_A" and handover.to_drone == "QUAD_B"
    assert [lg.drone_id for lg in record.legs if lg.role is LegRole.REPLACEMENT] == ["QUAD_B"]
    assert_each_waypoint_once(record)


async def test_a_ground_killed_between_writing_a_recovery_and_sending_it_sends_it_again(
    monkeypatch,
):
    """The handover and the failing drone's recovery leg are written, and the ground dies before
    the recovery reaches the broker (the real topology's failure: the alarm is then delivered
    again and known, so nothing answers it): the restarted planner sends the recovery again, so
    QUAD_A stops flying its leg before QUAD_B is given the rest; no waypoint is flown twice."""
    written = asyncio.Event()
    send_leg = MissionPlanner.send_leg

    async def dies_before_publishing(self, record, leg):
        if leg.role is not LegRole.RECOVERY:
            return await send_leg(self, record, leg)
        if record.leg(leg.leg_id) is None:
            record.legs.append(leg)
        await self.save(record)
        written.set()
        await asyncio.Event().wait()  # the ground is killed here

    monkeypatch.setattr(MissionPlanner, "send_leg", dies_before_publishing)
    # The drone's answer that it never got the recovery (asked for its reports at the ground's
    # start) makes the planner send it again too, but on a loaded host only after the handover's
    # wait: left out here, so the restart alone must send it.
    forgotten = reconcile.forgotten

    async def too_late(planner, record, leg):
        if leg.role is not LegRole.RECOVERY:
            await forgotten(planner, record, leg)

    monkeypatch.setattr(reconcile, "forgotten", too_late)
    same_credentials(monkeypatch)

    async def sends_again() -> None:
        monkeypatch.setattr(MissionPlanner, "send_leg", send_leg)

    async with Harness(speedup=10) as h:
        record = await restart_ground_after(h, ON_ALARM, written, while_down=sends_again)
    assert record.state is MissionState.COMPLETED, record.error
    (handover,) = record.handovers
    assert handover.from_drone == "QUAD_A" and handover.to_drone == "QUAD_B"
    assert_each_waypoint_once(record)
