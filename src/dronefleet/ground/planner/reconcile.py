"""Missions reconcile instead of hanging (issue 13).

- After a reconnect to the broker (not only at start), the planner asks every drone of every
  unfinished mission to re-send its reports for each of its legs: whatever was published while
  the link was down arrives, and duplicates are dropped by step.
- Reports are numbered per leg (``MissionProgress.seq``); a gap in the numbers received means
  some were lost on the way, and the drone is asked for them again (:func:`fill_gap`).
- A drone the Drone Identifier declares lost has its work taken over if it stays lost for a
  confirmation period, and the takeover is called off if it is heard again before its
  replacement has started (ground/planner/lost.py).
- A drone back online is sent its active legs again (a restarted drone forgot them) and asked
  for its reports, so what it did while unheard is recorded.
- At a ground's start, handovers a restart interrupted are finished (:func:`resume`) before any
  live report or alarm is read, and drones the Identifier still has lost are watched again.
- A drone whose heartbeats name no mission while a leg of ours runs on it (restarted faster than
  it could be missed) is asked for its reports too (:func:`on_heartbeat`).
"""

from __future__ import annotations

import asyncio
import logging
import secrets
import time
from typing import TYPE_CHECKING, Any

from dronefleet.ground.fleet import sleep_awake
from dronefleet.ground.planner import lost, replacement
from dronefleet.ground.planner.models import Leg, LegState, MissionRecord, MissionState
from dronefleet.messaging.client import QOS_COMMAND
from dronefleet.messaging.codec import MessageError
from dronefleet.messaging.ground_events import FleetChange, FleetEvent
from dronefleet.messaging.inbound import parse_message
from dronefleet.messaging.missions import (
    MissionAction,
    MissionProgress,
    MissionRequest,
    ProgressEvent,
)
from dronefleet.messaging.status import Heartbeat
from dronefleet.messaging.topics import Channel, Direction, topic

if TYPE_CHECKING:
    from dronefleet.ground.planner.service import MissionPlanner

log = logging.getLogger(__name__)

#: The request ids of the planner's report requests start so; a drone echoes them.
REPORT_PREFIX = "report-"
#: How often the planner looks whether its broker link was made again (event-loop seconds).
RECONNECT_POLL_S = 1.0
#: Wall seconds between two requests for a leg's missing reports.
GAP_ASK_S = 2.0
#: Wall seconds at most a mission waits for a leg's missing reports before it settles.
GAP_HOLD_S = 30.0
#: Heartbeats in a row naming no mission, or another, before a running leg is checked.
MISMATCHED_BEATS = 2


async def ask_reports(planner: MissionPlanner, drone_id: str | None = None) -> None:
    """Ask for the reports of every leg of every unfinished mission (of ``drone_id`` only)."""
    for record in list(planner.missions.values()):
        if record.terminal:
            continue
        for leg in record.legs:
            if drone_id is None or leg.drone_id == drone_id:
                await ask_leg_reports(planner, leg)


async def ask_leg_reports(planner: MissionPlanner, leg: Leg) -> None:
    """Ask ``leg``'s drone to re-send every report of it (duplicates are dropped by number)."""
    request = MissionRequest(
        request_id=f"{REPORT_PREFIX}{secrets.token_hex(8)}",
        mission_id=leg.leg_id,
        action=MissionAction.REPORT,
    )
    await planner.client.publish(
        topic(leg.drone_id, Channel.MISSION, Direction.IN), request, qos=QOS_COMMAND
    )


async def fill_gap(planner: MissionPlanner, leg: Leg) -> None:
    """Reports of ``leg`` are missing (a gap in their numbers): ask for them, at most once per
    :data:`GAP_ASK_S` (the drone sends them all again; one request covers every gap)."""
    now = time.monotonic()
    if now - planner.gap_asked.get(leg.leg_id, -GAP_ASK_S) < GAP_ASK_S:
        return
    planner.gap_asked[leg.leg_id] = now
    log.info("leg %s: reports %s missing; asking again", leg.leg_id, missing(leg.seqs))
    await ask_leg_reports(planner, leg)


def missing(seqs: list[int]) -> list[int]:
    have = set(seqs)
    return [n for n in range(1, (seqs[-1] if seqs else 0) + 1) if n not in have]


def answers_a_report_request(progress: MissionProgress) -> bool:
    """A drone's refusal of :func:`ask_reports`: it keeps no report of that leg."""
    return progress.event is ProgressEvent.REJECTED and (progress.request_id or "").startswith(
        REPORT_PREFIX
    )


async def forgotten(planner: MissionPlanner, record: MissionRecord, leg: Leg) -> None:
    """The drone keeps nothing of ``leg``: it never got it (sent again), or it was restarted
    and lost it mid-flight (its work is taken over, as a lost drone's)."""
    if record.terminal or not leg.active:
        return
    if leg.state is LegState.SENT or leg.role.outgoing:
        log.info(
            "mission %s: %s never got leg %s; sending it again",
            record.mission_id,
            leg.drone_id,
            leg.leg_id,
        )
        await planner.send_leg(record, leg)
        return
    why = f"drone {leg.drone_id} no longer knows leg {leg.leg_id} (restarted?)"
    while await lost.take_over(planner, record, leg, why):  # nobody now: again later
        await sleep_awake(lost.RETRY_S)
        if record.terminal or not leg.active or record.handed_over(leg):
            return


async def on_heartbeat(planner: MissionPlanner, beat: Heartbeat) -> None:
    """A drone that says it flies no mission (or another) while a leg of ours is running on it
    was restarted, or dropped the leg: after :data:`MISMATCHED_BEATS` such heartbeats its
    reports are asked for. It sends what it kept and says the leg was interrupted, or that it
    keeps nothing: either way the rest is taken over (:func:`forgotten`). A leg sent and never
    accepted is asked about the same way: a drone that never got it (sent while its link was
    down) says it keeps nothing of it, and is sent it again (issue 26: a lost drone's way home,
    sent as it came back, never arrived, and the mission never ended)."""
    running = [
        leg
        for record in list(planner.missions.values())
        if not record.terminal
        for leg in record.active_legs()
        if leg.drone_id == beat.drone_id
    ]
    if all(leg.leg_id == beat.mission_id for leg in running):
        planner.mismatched.pop(beat.drone_id, None)
        return
    count = planner.mismatched[beat.drone_id] = planner.mismatched.get(beat.drone_id, 0) + 1
    if count < MISMATCHED_BEATS:
        return
    for leg in running:
        if leg.leg_id != beat.mission_id:
            log.info("drone %s flies %s, not leg %s", beat.drone_id, beat.mission_id, leg.leg_id)
            await fill_gap(planner, leg)


async def resume(planner: MissionPlanner) -> None:
    """At start, with the planner's lock held (no live report or alarm is read meanwhile):
    finish what a ground restart interrupted (handovers decided, nobody chosen), and watch
    again the drones the Drone Identifier still has lost."""
    for record in list(planner.missions.values()):
        if not record.terminal:
            await replacement.resume(planner, record)
    if not any(not r.terminal and r.active_legs() for r in planner.missions.values()):
        return
    try:
        drones = await planner.fleet.records()
    except Exception as exc:
        log.warning("planner: the Drone Identifier did not answer at start: %s", exc)
        return
    for drone in drones:
        if drone.get("status") == "lost" and isinstance(drone.get("drone_id"), str):
            on_lost(planner, drone["drone_id"], drone)


async def watch_reconnects(planner: MissionPlanner) -> None:
    """Catch up each time the broker link is made again."""
    seen = planner.client.connections
    while True:
        await asyncio.sleep(RECONNECT_POLL_S)
        now = planner.client.connections
        if now != seen and planner.client.connected:
            seen = now
            log.info("planner: broker link back; asking the drones for their reports")
            await ask_reports(planner)


async def on_fleet_event(planner: MissionPlanner, topic_name: str, payload: bytes) -> None:
    try:
        event = parse_message(FleetEvent, payload)
    except MessageError as exc:
        log.debug("planner: dropping fleet event on %s: %s", topic_name, exc)
        return
    if event.event is FleetChange.LOST:
        on_lost(planner, event.drone_id, event.drone)
    elif event.event is FleetChange.ONLINE:
        await back_online(planner, event.drone_id)


def on_lost(planner: MissionPlanner, drone_id: str, heard: dict[str, Any] | None) -> None:
    """``drone_id`` is declared lost: each of its legs doing work is taken over if it stays lost
    (:func:`lost.confirm`); nothing is done to it meanwhile."""
    if drone_id not in planner.lost:
        planner.lost.add(drone_id)
        planner.lost_epochs[drone_id] = planner.lost_epochs.get(drone_id, 0) + 1
    epoch = planner.lost_epochs[drone_id]
    for record in list(planner.missions.values()):
        leg = None if record.terminal else record.leg_of(drone_id)
        if leg is None or leg.role.outgoing or leg.leg_id in planner.confirming:
            continue
        planner.confirming.add(leg.leg_id)
        planner.spawn(lost.confirm(planner, record, leg, heard, epoch), f"lost:{leg.leg_id}")


async def back_online(planner: MissionPlanner, drone_id: str) -> None:
    """``drone_id`` is heard again: a takeover of its work not yet started is called off (it
    keeps its leg), a mission it stalled runs again, a leg taking it out is sent again (it may
    have been restarted), and its reports are asked for."""
    if drone_id in planner.lost:
        planner.lost.discard(drone_id)
        planner.lost_epochs[drone_id] = planner.lost_epochs.get(drone_id, 0) + 1
    await lost.cancel(planner, drone_id)
    for record in list(planner.missions.values()):
        for leg in record.active_legs():
            if leg.drone_id != drone_id:
                continue
            if (
                record.state is MissionState.STALLED
                and not record.handed_over(leg)
                and not lost.stalled_by_others(planner, record, drone_id)
            ):
                await lost.unstall(planner, record, f"drone {leg.drone_id} is back")
            if leg.role.outgoing:
                await planner.send_leg(record, leg)  # again: it may have been restarted
                if record.terminal:
                    # A mission that completed while it was lost on its way out: what it flew
                    # unheard is asked for too, and kept (reports.late).
                    for own in record.legs:
                        if own.drone_id == drone_id:
                            await ask_leg_reports(planner, own)
    await ask_reports(planner, drone_id)
