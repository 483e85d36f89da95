"""Mission Worker (seed 3.3.2.2, 4.1.2.3): decodes missions, queues the steps, runs them in order.

A mission arrives whole on ``mission/in`` (base64 as the seed's planner sends it, or JSON). It is
decoded and checked before anything changes: a bad mission is rejected with the reason and the
running one carries on. A good one replaces whatever was running. Each step done is reported on
``mission/out`` with its index, command, position, duration (vehicle seconds) and the decode time.
On a MAVLink autopilot a mission may be flown on board instead (:mod:`dronefleet.drone.onboard`).
Elsewhere: pausing and resuming a mission (drone/mission_pause.py), building and replaying the
reports (drone/progress_reports.py), the steps the Drone Controller does not run itself
(drone/step_actions.py).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections import deque
from typing import Any

from dronefleet.clock import timestamp_s
from dronefleet.drone import mission_pause, onboard, progress_reports, safe_end, step_actions
from dronefleet.drone.autopilot_fence import AutopilotFence
from dronefleet.drone.controller import CommandError, DroneController
from dronefleet.drone.direct_commands import FlyingMission
from dronefleet.drone.outbox import Outbox
from dronefleet.drone.report_history import ReportHistory
from dronefleet.drone.step_actions import StepFailed
from dronefleet.drone.takeover import DIRECT, OPERATOR, POLL_S, Paused, Takeover
from dronefleet.messaging.client import QOS_COMMAND
from dronefleet.messaging.codec import MessageError, decode_object
from dronefleet.messaging.common import validate
from dronefleet.messaging.fence import Geofence, RallyPoint
from dronefleet.messaging.log_throttle import LogThrottle
from dronefleet.messaging.missions import (
    MissionAction,
    MissionProgress,
    MissionRequest,
    ProgressEvent,
    decode_steps,
    request_ids,
)
from dronefleet.messaging.topics import Channel, Direction
from dronefleet.tasks import cancel_and_wait
from dronefleet.vehicle.base import FcError

log = logging.getLogger(__name__)
#: Longest a direct command waits for the mission it interrupts to pause (wall seconds): the
#: mission looks every POLL_S vehicle seconds.
YIELD_WAIT_S = 2.0
_throttle = LogThrottle(
    log
)  # one line per kind per 10 s: junk on the broker must not flood the log


class MissionWorker:
    """Runs one mission at a time on a Drone Controller."""

    def __init__(self, controller: DroneController) -> None:
        self.controller = controller
        self.config = controller.config
        self.clock = controller.clock
        self.client = controller.client
        self.outbox = Outbox(controller.client)  # reports and alarms, never awaited by a mission
        self.queue: deque[Any] = deque()  # the internal task queue of Figure 4.14
        self.mission_id: str | None = None
        self._task: asyncio.Task[None] | None = None
        self._lock = asyncio.Lock()
        self.sensors = step_actions.SensorReadings(controller)  # read_sensors steps
        # Every report of the last missions, numbered, re-sent on request to a planner that
        # missed some; on disk too with a state folder (drone/report_history.py).
        state_dir = self.config.state_dir
        self.reports = ReportHistory(self.clock, state_dir / "reports.db" if state_dir else None)
        self.steps: list[tuple[int, Any]] = []  # the mission's steps, with their indices
        self.steps_done: set[int] = set()  # indices of its steps reported done
        self.paused: Paused | None = None  # a mission someone else took the vehicle from
        self._asked: Takeover | None = None  # a pause asked for, for the running mission
        self.fence: Geofence | None = None  # the running mission's geofence
        # The fence and rally points a MAVLink autopilot gets before a mission flies.
        self.autopilot_fence = AutopilotFence(controller.fc)
        self._for_autopilot: tuple[Geofence | None, list[RallyPoint]] | None = None
        controller.missions = self  # direct commands ask who flies the vehicle

    async def start(self) -> None:
        await self.client.subscribe(
            self.controller.topic(Channel.MISSION, Direction.IN), self._on_mission
        )

    async def stop(self) -> None:
        await self._cancel_current()
        await self.outbox.drain(timeout_s=2.0)  # the last reports, if the broker is there
        await self.outbox.close()
        self.reports.close()

    @property
    def running(self) -> bool:
        return self._task is not None and not self._task.done()

    def flying(self) -> FlyingMission | None:
        """The mission flying the vehicle now (not paused, not ended), for direct commands."""
        if not self.running or self.mission_id is None:
            return None
        last = self.steps[-1][0] if self.steps else 0
        return FlyingMission(self.mission_id, self.controller.step_index, last)

    async def yield_to(self, command: str, note: str) -> None:
        """Pause the flying mission for a direct ``command`` obeyed now (drone/
        direct_commands.py): reported ``paused`` with the command and ``note`` (who sent it),
        without holding (the command flies the vehicle next); the ground may resume it."""
        async with self._lock:
            task = self._task
            if task is None or task.done():
                return
            self._asked = Takeover(command, DIRECT, note, round(self.clock.now(), 3))
            done, _ = await asyncio.wait({task}, timeout=YIELD_WAIT_S)
            if not done:
                what = "%s: mission %s did not pause for %s within %g s"
                log.warning(what, self.controller.drone_id, self.mission_id, command, YIELD_WAIT_S)

    # -- mission/in --------------------------------------------------------------------------
    async def _on_mission(self, _topic: str, payload: bytes) -> None:
        started = time.perf_counter()
        request_id, mission_id = request_ids(payload)
        try:
            request = validate(MissionRequest, decode_object(payload))
            steps = decode_steps(request) if request.action is MissionAction.START else []
        except MessageError as exc:
            _throttle.log(
                logging.INFO, "mission", "%s: mission rejected: %s", self.controller.drone_id, exc
            )
            await self.report(
                ProgressEvent.REJECTED,
                mission_id or "",
                request_id=request_id,
                ok=False,
                error=str(exc),
            )
            return
        decode_time_s = time.perf_counter() - started
        if request.action is MissionAction.REPORT:
            await self._replay(request.mission_id, request_id)
            return
        async with self._lock:
            if request.action is MissionAction.RESUME:
                await self._resume(request.mission_id, request_id)
                return
            if request.action is MissionAction.PAUSE:  # done by _run within POLL_S
                if self.running and request.mission_id == self.mission_id:
                    self._asked = Takeover("HOLD", OPERATOR, None, round(self.clock.now(), 3))
                return
            if request.action is MissionAction.STOP:
                stopped = self.mission_id
                await self._cancel_current(reason="stopped on request", request_id=request_id)
                if self._in_air():
                    await self.controller.navigation.hold()
                if stopped is None:
                    await self.report(
                        ProgressEvent.STOPPED,
                        request.mission_id,
                        request_id=request_id,
                        result={"note": "no mission was running"},
                    )
                return
            mission_id = request.mission_id or f"m-{int(timestamp_s() * 1000)}"
            await self._cancel_current(reason=f"replaced by mission {mission_id}")
            self.queue = deque(enumerate(steps, start=request.start_index))
            self.steps, self.steps_done, self._asked = list(self.queue), set(), None
            self.fence = request.fence  # kept to in flight (drone/fence_guard.py)
            navigation = self.controller.navigation  # where an early return may land instead
            navigation.rally_points, navigation.fence = list(request.rally), request.fence
            self._for_autopilot = (request.fence, list(request.rally))
            self.mission_id = mission_id
            self.controller.mission_id = mission_id
            await self.report(
                ProgressEvent.ACCEPTED,
                mission_id,
                request_id=request_id,
                step_count=len(steps),
                decode_time_s=round(decode_time_s, 6),
            )
            self._task = asyncio.create_task(
                self._run(mission_id, len(steps), request.start_index, request.onboard),
                name=f"mission:{mission_id}",
            )

    async def abandon(self, reason: str) -> None:
        """Stop the running mission for ``reason`` (reported ``stopped``), as a stop request
        would, but leaving what the vehicle does next to the caller (drone/link_loss.py)."""
        async with self._lock:
            await self._cancel_current(reason=reason)

    async def _cancel_current(self, *, reason: str = "", request_id: str | None = None) -> None:
        task, mission_id = self._task, self.mission_id
        paused, self.paused = self.paused, None
        if paused is not None:  # nothing runs: the vehicle is someone else's until now
            await self.report(
                ProgressEvent.STOPPED,
                paused.mission_id,
                request_id=request_id,
                error=f"{reason or 'stopped'} (while paused)",
            )
        elif task is not None and not task.done():
            await self.controller.camera_trigger.stop()
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
            await self.report(
                ProgressEvent.STOPPED,
                mission_id or "",
                request_id=request_id,
                step_index=self.controller.step_index,
                error=reason or None,
            )
        self._task = None
        self.queue.clear()
        self.mission_id = None
        self.controller.mission_id = None

    # -- running -----------------------------------------------------------------------------
    async def _run(
        self, mission_id: str, count: int, start_index: int, onboard_requested: bool | None = None
    ) -> None:
        """Fly the mission, looking at the flight mode every telemetry period: a mode this
        drone did not choose pauses it (drone/takeover.py)."""
        flying = asyncio.create_task(
            self._fly(mission_id, count, start_index, onboard_requested), name=f"fly:{mission_id}"
        )
        modes = self.controller.navigation.modes
        try:
            while not flying.done():
                taken = self._asked or modes.takeover() or mission_pause.link_lost(self.controller)
                self._asked = None
                if taken is not None:
                    await cancel_and_wait(flying)
                    if taken.by == OPERATOR and self._in_air():
                        await self.controller.navigation.hold()
                    await mission_pause.pause(self, mission_id, count, start_index, taken)
                    return
                tick = asyncio.ensure_future(self.clock.sleep(POLL_S))
                await asyncio.wait({flying, tick}, return_when=asyncio.FIRST_COMPLETED)
                await cancel_and_wait(tick)
            flying.result()
        finally:
            await cancel_and_wait(flying)

    async def _resume(self, mission_id: str, request_id: str | None) -> None:
        """Fly on with the paused mission ``mission_id`` (drone/mission_pause.py)."""
        resumed = await mission_pause.resume(self, mission_id, request_id)
        if resumed is None:
            return
        paused, left = resumed
        self.queue = deque(left)
        self._task = asyncio.create_task(
            self._run(mission_id, paused.count, paused.start_index, onboard_requested=False),
            name=f"mission:{mission_id}",
        )

    async def _fly(
        self, mission_id: str, count: int, start_index: int, onboard_requested: bool | None = None
    ) -> None:
        mission_started = self.clock.now()
        trigger = self.controller.camera_trigger
        trigger.reset()
        self.sensors.forget()
        steps = list(self.queue)
        if not await self._fence_on_board(mission_id, count, steps):
            return
        if await onboard.fly(self, mission_id, steps, count, onboard_requested):  # on board
            self.queue.clear()
            self._finish()
            return
        while self.queue:
            index, step = self.queue.popleft()
            self.controller.step_index = index
            began = self.clock.now()
            try:
                result = await self.execute_step(step)
            except (CommandError, FcError, StepFailed) as exc:
                if not getattr(self.controller.fc, "connected", True):
                    # The autopilot is gone, not the step: _run pauses the mission within
                    # POLL_S (the step is flown again on a resume).
                    await asyncio.Future()
                await trigger.stop()
                then = await safe_end.fly_the_end(self.controller, self.queue)
                await self.report(
                    ProgressEvent.FAILED,
                    mission_id,
                    step_index=index,
                    step_count=count,
                    command=str(step.command),
                    ok=False,
                    error=f"{exc}; {then}" if then else str(exc),
                    step_started_s=began,
                    step_duration_s=self.clock.now() - began,
                )
                self._finish()
                return
            await self.report(
                ProgressEvent.STEP,
                mission_id,
                step_index=index,
                step_count=count,
                command=str(step.command),
                step_started_s=began,
                step_duration_s=self.clock.now() - began,
                result=result or None,
            )
        await trigger.stop()
        await self.report(
            ProgressEvent.COMPLETED,
            mission_id,
            step_count=count,
            step_started_s=mission_started,
            step_duration_s=self.clock.now() - mission_started,
            step_index=start_index + count - 1,
            result={"triggered_pictures": len(trigger.pictures)},
        )
        self._finish()

    async def _fence_on_board(self, mission_id: str, count: int, steps: list[Any]) -> bool:
        """Put the new mission's fence and rally points on board the autopilot (MAVLink; not
        again on a resume): False, the mission failed with the reason, when it would not."""
        wanted, self._for_autopilot = self._for_autopilot, None
        if wanted is None:
            return True
        try:
            put = await self.autopilot_fence.prepare(*wanted)
        except FcError as exc:
            await self.report(
                ProgressEvent.FAILED,
                mission_id,
                step_index=steps[0][0] if steps else None,
                step_count=count,
                ok=False,
                error=f"not flown: {exc}",
            )
            self._finish()
            return False
        if put:
            log.info("%s: on board the autopilot: %s", self.controller.drone_id, put)
        return True

    def _finish(self) -> None:
        self.mission_id = None
        self.controller.mission_id = None
        self.controller.step_index = None

    async def execute_step(self, step: Any) -> dict[str, Any]:
        """Run one step: control commands go to the controller; the rest are step_actions'."""
        return await step_actions.execute(
            self.controller, step, self.outbox, self.sensors, self.mission_id
        )

    def _in_air(self) -> bool:
        return self.controller.fc.state().in_air

    async def report(self, event: ProgressEvent, mission_id: str, **fields: Any) -> None:
        """Publish a report of ``event`` where the vehicle is now (drone/progress_reports.py)."""
        await self.publish(progress_reports.progress(self.controller, event, mission_id, **fields))

    async def publish(self, progress: MissionProgress) -> None:
        """Publish a report (QoS 1) and keep it for :meth:`_replay` (not a rejection: it answers a
        request that never became a mission)."""
        if progress.event is ProgressEvent.STEP and progress.mission_id == self.mission_id:
            self.steps_done.add(progress.step_index if progress.step_index is not None else -1)
        self.reports.keep(progress)  # numbered; the ground asks again for a gap in them
        topic_name = self.controller.topic(Channel.MISSION)
        if progress.event is ProgressEvent.REJECTED:
            # An answer to a request that never became a mission (junk, or a report of a leg it
            # does not know): sent as it comes, so a flood of junk waits on the broker rather
            # than filling the outbox (tests/integration/test_flood.py).
            await self.client.publish(topic_name, progress, qos=QOS_COMMAND)
            return
        await self.controller.status.tell_state()  # a landing is heard before its report
        # Never awaited: a broker outage must not stop the mission (drone/outbox.py).
        self.outbox.post(topic_name, progress)

    async def _replay(self, mission_id: str, request_id: str | None) -> None:
        """Re-send every report of ``mission_id``, in order; readers drop the duplicates."""
        await progress_reports.replay(self, mission_id, request_id)
