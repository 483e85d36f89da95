"""Missions flown on board (issue 6): the Mission Worker hands a whole mission to the autopilot.

The seed's Mission Worker runs every step from the companion computer, so a mission stops when the
drone software or its link does (sections 3.3.3, 6.2). A MAVLink autopilot can fly a mission by
itself: this module turns a step list into MISSION_ITEM_INTs, uploads it, starts AUTO and turns the
autopilot's MISSION_CURRENT / MISSION_ITEM_REACHED back into the same per-step
:class:`~dronefleet.messaging.missions.MissionProgress` reports on ``<id>/mission/out``.

When: the flight controller has a ``mission`` facade (MAVLink), every step is one the autopilot can
fly (:data:`FLYABLE`; ``arm`` only before the first flying step), and the mission asks for it
(``MissionRequest.onboard``, from the planner's ``options.onboard``) or, when it does not say, the
drone is configured for it (``DroneConfig.onboard_missions``, ``dronefleet drone
--onboard-missions``) or the mission has at least :data:`ONBOARD_MIN_STEPS` steps. A mission that
is wanted on board but cannot be (a step with no on-board form, a failed upload) flies from the
companion computer, and the drone's log says why; the planner refuses one the operator asked on
board that cannot be, and says so on the leg otherwise (ground/planner/launch.py).

Each report is built when the autopilot's event arrives (its vehicle time and position) and queued;
publishing is QoS 1, and the broker client waits out broker outages, so reports made while the
broker is down reach the ground, in order, when it is back — the vehicle meanwhile flies on.

Step → item: ``takeoff`` NAV_TAKEOFF, ``navigate`` NAV_WAYPOINT (done when it becomes current),
``wait_for_flight`` (done when the last waypoint is reached), ``sleep`` NAV_LOITER_TIME where the
vehicle is, ``land`` NAV_LAND, ``rtl`` NAV_RETURN_TO_LAUNCH (the autopilot's own RTL: to its RTL
altitude, home or its nearest rally point, then down; done when it has landed and disarmed), and
a mission that ends in the air (the ``hold`` end) ends with NAV_LOITER_UNLIM where it is, so the
autopilot holds there in AUTO until told otherwise. ArduPilot runs the DO items after a NAV item
when that item completes (``AP_Mission::advance_current_nav_cmd``), so a picture needs no stop
of its own: ``takepic`` right after a waypoint is a DO_DIGICAM_CONTROL after it (taken as the
waypoint is reached, flown through), ``camera_trigger`` a DO_SET_CAM_TRIGG_DIST after it (a
fly-through survey line: first picture at the line's start, then every N metres, off at its end
— as QGroundControl's surveys fly). Only a ``takepic`` with no waypoint before it becomes a
zero-second loiter and the picture. The end of a mission that stays up is seen as its
NAV_LOITER_UNLIM becoming current; one that comes down (LAND, RTL) ends landed and disarmed.
The autopilot's CAMERA_FEEDBACK / CAMERA_IMAGE_CAPTURED count is the mission's photo count.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from dronefleet.drone.state import position_of
from dronefleet.messaging.commands import Command
from dronefleet.messaging.missions import MissionProgress, ProgressEvent
from dronefleet.protocols.mavlink.items import ONBOARD_STEPS, onboard_refusal
from dronefleet.vehicle.base import FcError, FlightMode

if TYPE_CHECKING:
    from dronefleet.drone.mission_worker import MissionWorker

log = logging.getLogger(__name__)

#: Missions with at least this many steps go on board even without the flag (None: never).
ONBOARD_MIN_STEPS: int | None = None
#: Step commands the autopilot can fly (protocols/mavlink/items.py, shared with the planner).
FLYABLE = frozenset(Command(c) for c in ONBOARD_STEPS)
#: Vehicle seconds out of AUTO (or disarmed) before the mission counts as abandoned.
LEFT_AUTO_GRACE_S = 3.0


@dataclass(frozen=True, slots=True)
class OnboardPlan:
    """The items to upload, the steps run from here first (``arm``) and, for every other step,
    the progress level at which it is done (2·index when its item becomes current, 2·index + 1
    when reached; index in the uploaded list)."""

    items: list[Any]
    prefix: list[tuple[int, Any]]
    thresholds: list[tuple[int, Any, int]]  # (step index, step, level)


def wanted(
    worker: MissionWorker, steps: list[tuple[int, Any]], requested: bool | None = None
) -> bool:
    fc = worker.controller.fc
    if getattr(fc, "mission", None) is None or not steps:
        return False
    if requested is not None:
        return requested
    if worker.config.onboard_missions:
        return True
    return ONBOARD_MIN_STEPS is not None and len(steps) >= ONBOARD_MIN_STEPS


class _Items:
    """The mission items being built, where they fly, and the progress level of each step."""

    def __init__(self, alt_m: float, goal: tuple[float, float], takeoff_alt_m: float) -> None:
        self.items: list[Any] = []
        self.alt_m, self.goal, self.takeoff_alt_m = alt_m, goal, takeoff_alt_m
        self.at_goal = False  # the last NAV item is a waypoint at ``goal``: a photo flies through

    def after_nav(self) -> int:
        """The level at which a DO item appended now runs: its NAV item's completion."""
        navs = [i for i, item in enumerate(self.items) if item.is_nav]
        return 2 * navs[-1] + 1 if navs else 0

    def nav(self, item: Any, *, at_goal: bool = False) -> int:
        self.items.append(item)
        self.at_goal = at_goal
        return 2 * (len(self.items) - 1)  # done when it becomes current

    def add(self, step: Any) -> int:
        """Append ``step``'s items; the level at which the step is done."""
        from dronefleet.protocols.mavlink import items as mi

        command = step.command
        if command is Command.TAKEOFF:
            self.alt_m = step.value if step.value is not None else self.takeoff_alt_m
            return self.nav(mi.takeoff(self.alt_m))
        if command is Command.NAVIGATE:
            if step.altitude_delta is not None:
                self.alt_m = step.altitude_delta
            self.goal = (step.lat, step.lon)
            return self.nav(mi.waypoint(step.lat, step.lon, self.alt_m), at_goal=True)
        if command is Command.SLEEP:
            seconds = float(step.value or 0.0)
            return self.nav(mi.loiter_time(*self.goal, self.alt_m, seconds)) + 2  # next starts
        if command is Command.LAND:
            return self.nav(mi.land())
        if command is Command.RTL:
            return self.nav(mi.return_to_launch())
        if command is Command.TAKEPIC:
            if not self.at_goal:  # nothing to fly through: stop here for the picture
                self.nav(mi.loiter_time(*self.goal, self.alt_m, 0.0))
            self.items.append(mi.take_photo())
        elif command is Command.CAMERA_TRIGGER:
            self.items.append(mi.trigger_distance(float(step.value or 0.0)))
        return self.after_nav()  # these and WAIT_FOR_FLIGHT: when the NAV item before is done


def refusal(steps: list[tuple[int, Any]]) -> str | None:
    """Why ``steps`` cannot be flown on board (naming the step), or None."""
    found = onboard_refusal([str(step.command) for _, step in steps])
    if found is None:
        return None
    k, why = found
    return f"step {steps[k][0]} ({steps[k][1].command}): {why}"


def plan(worker: MissionWorker, steps: list[tuple[int, Any]]) -> OnboardPlan | None:
    """The on-board form of ``steps``, or None when some step cannot be flown on board."""
    from dronefleet.protocols.mavlink import items as mi
    from dronefleet.protocols.mavlink.codec import dialect

    if refusal(steps) is not None:
        return None
    fc, config = worker.controller.fc, worker.config
    here, home = fc.position(), fc.home()
    alt_m = here.alt_m - home.alt_m if fc.state().in_air else config.takeoff_altitude_m
    built = _Items(alt_m, (here.lat, here.lon), config.takeoff_altitude_m)
    prefix: list[tuple[int, Any]] = []
    thresholds: list[tuple[int, Any, int]] = []
    for index, step in steps:
        if step.command is Command.ARM:
            prefix.append((index, step))
        else:
            thresholds.append((index, step, built.add(step)))
    items = built.items
    if not items:
        return None
    navs = [item for item in items if item.is_nav]
    down = {dialect.MAV_CMD_NAV_LAND, dialect.MAV_CMD_NAV_RETURN_TO_LAUNCH}
    if navs[-1].command not in down:
        # It ends in the air: hold there, in AUTO, until told otherwise (the ``hold`` end); the
        # loiter's start marks the end of what came before.
        items.append(mi.loiter_unlimited(*built.goal, built.alt_m))
    return OnboardPlan(items, prefix, thresholds)


async def fly(
    worker: MissionWorker,
    mission_id: str,
    steps: list[tuple[int, Any]],
    count: int,
    requested: bool | None = None,
) -> bool:
    """Fly ``steps`` on board, reporting each; False (nothing done) when they cannot be."""
    if not wanted(worker, steps, requested):
        return False
    if (onboard := plan(worker, steps)) is None:
        why = refusal(steps) or "nothing to fly on board"
        log.warning(
            "%s: mission %s flies from the companion computer, not on board: %s",
            worker.config.drone_id, mission_id, why,
        )  # fmt: skip
        return False
    fc: Any = worker.controller.fc  # a backend with a ``mission`` facade (wanted() checked)
    try:
        await fc.mission.upload(onboard.items, home=fc.home())
    except FcError as exc:
        log.warning("%s: on-board upload failed, flying from here: %s", worker.config.drone_id, exc)
        return False
    log.info(
        "%s: mission %s flies on board (%d items)",
        worker.config.drone_id,
        mission_id,
        len(onboard.items),
    )
    outbox: asyncio.Queue[MissionProgress | None] = asyncio.Queue()
    publisher = asyncio.create_task(_publish(worker, outbox), name=f"onboard-out:{mission_id}")
    try:
        await _run(worker, fc, onboard, mission_id, count, outbox)
    except asyncio.CancelledError:
        with contextlib.suppress(Exception):
            if fc.state().mode is FlightMode.MISSION:
                async with worker.controller.navigation.modes.choosing():
                    await fc.hold()  # stop the autopilot's mission too
        raise
    finally:
        outbox.put_nowait(None)
        with contextlib.suppress(Exception):
            await asyncio.shield(publisher)
    return True


async def _run(worker, fc, onboard: OnboardPlan, mission_id: str, count: int, outbox) -> None:
    from dronefleet.protocols.mavlink.codec import dialect

    clock = worker.clock
    started = clock.now()

    def report(event: ProgressEvent, **fields: Any) -> None:
        for key in ("step_started_s", "step_duration_s"):
            if fields.get(key) is not None:
                fields[key] = round(fields[key], 3)
        outbox.put_nowait(
            MissionProgress(
                drone_id=worker.config.drone_id,
                mission_id=mission_id,
                event=event,
                position=position_of(fc.position(), fc.home()),
                vehicle_time_s=round(clock.now(), 3),
                **fields,
            )
        )

    def about(event: ProgressEvent, index: int, step: Any, **fields: Any) -> None:
        report(event, step_index=index, step_count=count, command=str(step.command), **fields)

    for index, step in onboard.prefix:  # arming: from the companion computer, as usual
        worker.controller.step_index = index
        began = clock.now()
        try:
            result = await worker.execute_step(step)
        except Exception as exc:
            about(ProgressEvent.FAILED, index, step, ok=False, error=str(exc))
            return
        about(
            ProgressEvent.STEP,
            index,
            step,
            step_started_s=began,
            step_duration_s=clock.now() - began,
            result=result or None,
        )
    pending = list(onboard.thresholds)
    level = -1
    # ArduPilot reports no MISSION_ITEM_REACHED for a final NAV_LAND or NAV_RETURN_TO_LAUNCH: it
    # lands, disarms, and the mission goes back to item 1. Landed and disarmed once that item was
    # current is its end.
    down = {dialect.MAV_CMD_NAV_LAND, dialect.MAV_CMD_NAV_RETURN_TO_LAUNCH}
    lands = [i for i, item in enumerate(onboard.items) if item.command in down]
    land_level = 2 * lands[-1] if lands else None
    events: asyncio.Queue[Any] = asyncio.Queue()
    fc.mission.current_seq = None  # what was current before the upload says nothing now
    photos_before = fc.mission.photo_count
    pump = asyncio.create_task(_pump(fc, events), name=f"onboard-progress:{mission_id}")
    began = clock.now()
    try:
        async with worker.controller.navigation.modes.choosing():
            await fc.mission.start(0)
        left_since: float | None = None
        while pending:
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(0.25):
                    event = await events.get()
                level = max(level, 2 * event.index + (1 if event.kind == "reached" else 0))
            while pending and pending[0][2] <= level:
                index, step, _ = pending.pop(0)
                worker.controller.step_index = index
                now = clock.now()
                about(
                    ProgressEvent.STEP,
                    index,
                    step,
                    step_started_s=began,
                    step_duration_s=now - began,
                    result={"on_board": True},
                )
                began = now
            state = fc.state()
            landed = not state.armed and not state.in_air
            if pending and land_level is not None and level >= land_level and landed:
                level = 2 * len(onboard.items)  # every step up to the landing is done
                continue
            if pending and (state.mode is not FlightMode.MISSION or not state.armed):
                left_since = left_since if left_since is not None else clock.now()
                if clock.now() - left_since > LEFT_AUTO_GRACE_S:
                    index, step, _ = pending[0]
                    reason = (
                        f"the autopilot left the mission (mode {state.mode}, armed: {state.armed})"
                    )
                    about(ProgressEvent.FAILED, index, step, ok=False, error=reason)
                    return
            else:
                left_since = None
    except FcError as exc:
        failed_at = pending[0][0] if pending else None
        report(
            ProgressEvent.FAILED, step_index=failed_at, step_count=count, ok=False, error=str(exc)
        )
        return
    finally:
        pump.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await pump
    last = onboard.thresholds[-1][0] if onboard.thresholds else onboard.prefix[-1][0]
    report(
        ProgressEvent.COMPLETED,
        step_count=count,
        step_started_s=started,
        step_duration_s=clock.now() - started,
        step_index=last,
        result={"on_board": True, "photos": fc.mission.photo_count - photos_before},
    )


async def _pump(fc: Any, events: asyncio.Queue[Any]) -> None:
    async for event in fc.mission.progress():
        events.put_nowait(event)


async def _publish(worker: MissionWorker, outbox: asyncio.Queue[MissionProgress | None]) -> None:
    """Reports in order; each waits for the broker if it is down (QoS 1)."""
    while (progress := await outbox.get()) is not None:
        try:
            await worker.publish(progress)  # kept for replay, QoS 1
        except Exception:
            log.exception("%s: progress report lost", worker.config.drone_id)
