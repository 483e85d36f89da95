"""Mission Planner (seed 3.4.2.4, 4.2.4): missions out, progress in, drones replaced and joined.

It sends each drone its leg of a mission on ``<id>/mission/in``, follows ``+/mission/out`` and
``+/alarms/out``, and keeps every mission's state in the ground state store. Its broker session is
persistent (QoS 1), so progress and alarms published while the planner is down are delivered when
it comes back, and tracking carries on where it stopped. A CRITICAL alarm starts a replacement
(:mod:`.replacement`); an OUT_MEASURE alarm grows the area (:mod:`.collaboration`).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections import Counter
from collections.abc import Callable
from typing import Any

from dronefleet.clock import timestamp_s
from dronefleet.errors import Conflict, InvalidInput, NotFound
from dronefleet.ground.planner import paths, reconcile
from dronefleet.ground.planner.ends import GO_HOME
from dronefleet.ground.planner.fleet_view import FleetView
from dronefleet.ground.planner.mission_log import build_log
from dronefleet.ground.planner.models import (
    Leg,
    LegState,
    MissionRecord,
    MissionState,
)
from dronefleet.ground.planner.options import LegRole
from dronefleet.ground.planner.progress import apply_progress, note_seq
from dronefleet.ground.planner.store import MissionStore
from dronefleet.ground.planner.units import remaining
from dronefleet.ground.planner.worker import PlanningWorker
from dronefleet.ground.state import StateStore
from dronefleet.messaging.client import QOS_COMMAND, QOS_STREAM, BrokerClient
from dronefleet.messaging.codec import MessageError
from dronefleet.messaging.commands import AlarmLevel, Command
from dronefleet.messaging.ground_events import PlannerEvent
from dronefleet.messaging.inbound import parse_message, speaks_for_itself
from dronefleet.messaging.log_throttle import LogThrottle
from dronefleet.messaging.missions import (
    MissionAction,
    MissionProgress,
    MissionRequest,
    ProgressEvent,
)
from dronefleet.messaging.rpc import Requester
from dronefleet.messaging.status import Alarm, Telemetry
from dronefleet.messaging.topics import (
    IDENTIFIER_EVENTS,
    PLANNER_EVENTS,
    Channel,
    Direction,
    any_drone,
    topic,
)

log = logging.getLogger(__name__)
_throttle = LogThrottle(
    log
)  # one line per kind per 10 s: junk on the broker must not flood the log


class PlannerError(InvalidInput):
    """A mission the planner refuses as asked; the message says why (REST: 422).

    Refusals of another kind are :class:`~dronefleet.errors.NotFound` (no such mission or drone)
    and :class:`~dronefleet.errors.Conflict` (a drone lost or busy, a mission not planned).
    """


class MissionPlanner:
    def __init__(
        self,
        broker_url: Any,
        state: StateStore,
        *,
        client_id: str = "ground-planner",
        max_altitude_m: float = 120.0,
        reserve_pct: float = 20.0,
        worker: PlanningWorker | None = None,
    ) -> None:
        self.client = BrokerClient(broker_url, client_id, persistent_session=True)
        #: Reports and alarms dropped, by kind: malformed, or about another drone than the one
        #: whose topic they came on (issue 12: a forged alarm must start no replacement).
        self.dropped: Counter[str] = Counter()
        self.worker = worker or PlanningWorker()  # planning off the event loop, with a budget
        self.requester = Requester(self.client)
        self.fleet = FleetView(self.requester)
        self.store = MissionStore(state)
        self.max_altitude_m = max_altitude_m
        self.reserve_pct = reserve_pct
        self.missions: dict[str, MissionRecord] = {}
        self._legs: dict[str, str] = {}  # leg id -> mission id
        self._lock = asyncio.Lock()
        self._listeners: list[Callable[[str, dict[str, Any]], Any]] = []
        self._tasks: set[asyncio.Task[Any]] = set()
        self._dirty: set[str] = set()
        self._flusher: asyncio.Task[None] | None = None
        self.latest: dict[str, dict[str, Any]] = {}  # drone id -> latest telemetry fields
        self._checking: set[str] = set()  # legs whose early-replacement check is running
        self.gap_asked: dict[str, float] = {}  # leg id -> when its missing reports were asked
        self.mismatched: dict[str, int] = {}  # drone id -> heartbeats naming another mission
        self.lost: set[str] = set()  # drones the Drone Identifier last declared lost

    @property
    def lock(self) -> asyncio.Lock:
        """Held while a mission's legs change (ground/planner/ops.py)."""
        return self._lock

    @property
    def checking(self) -> set[str]:
        """Legs whose early-replacement check is running."""
        return self._checking

    # -- lifecycle ---------------------------------------------------------------------------
    async def start(self) -> MissionPlanner:
        await self.store.open()
        for record in await self.store.load_all():
            self._track(record)
        await self.client.start(timeout_s=None)
        await self.client.subscribe(any_drone(Channel.MISSION), self._on_progress, qos=QOS_COMMAND)
        await self.client.subscribe(any_drone(Channel.ALARMS), self._on_alarm, qos=QOS_COMMAND)
        await self.client.subscribe(
            any_drone(Channel.TELEMETRY), self._on_telemetry, qos=QOS_STREAM
        )
        await self.client.subscribe(
            any_drone(Channel.HEARTBEATS),
            lambda t, p: reconcile.on_heartbeat(self, t, p),
            qos=QOS_STREAM,
        )
        await self.client.subscribe(
            IDENTIFIER_EVENTS,
            lambda t, p: reconcile.on_fleet_event(self, t, p),
            qos=QOS_STREAM,
        )
        await self.client.wait_connected(15)
        self._flusher = asyncio.create_task(self._flush_paths(), name="planner:paths")
        # Whatever was published while the planner was away (not every broker queues for an
        # offline session) is asked for again, at start and after every reconnect.
        await reconcile.ask_reports(self)
        self.spawn(reconcile.resume(self), "planner:resume")
        self.spawn(reconcile.watch_reconnects(self), "planner:reconnects")
        return self

    async def stop(self) -> None:
        if self._flusher is not None:
            self._flusher.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._flusher
        for task in list(self._tasks):
            task.cancel()
        for record_id in list(self._dirty):
            with contextlib.suppress(Exception):
                await self.store.save(self.missions[record_id])
        await self.client.stop()
        await asyncio.get_running_loop().run_in_executor(None, self.worker.close)

    def _track(self, record: MissionRecord) -> None:
        self.missions[record.mission_id] = record
        for leg in record.legs:
            self._legs[leg.leg_id] = record.mission_id

    def add_listener(self, listener: Callable[[str, dict[str, Any]], Any]) -> None:
        """``listener(event, data)`` for every mission event (the WebSocket hub, experiments)."""
        self._listeners.append(listener)

    def emit(self, event: str, /, **data: Any) -> None:
        if event in ("mission", "handover", "expansion", "leg"):
            # Ground-wide announcement (the WebSocket stream); progress and alarms already
            # travel on the drones' own topics.
            self.spawn(self._announce(event, data), f"announce:{event}")
        for listener in self._listeners:
            try:
                listener(event, data)
            except Exception:
                log.exception("mission listener failed on %s", event)

    def spawn(self, coro: Any, name: str) -> None:
        task = asyncio.create_task(coro, name=name)
        self._tasks.add(task)
        task.add_done_callback(self._task_done)

    def _task_done(self, task: asyncio.Task[Any]) -> None:
        self._tasks.discard(task)
        if not task.cancelled() and task.exception() is not None:
            log.error("planner task %s failed", task.get_name(), exc_info=task.exception())

    async def _announce(self, event: str, data: dict[str, Any]) -> None:
        message = PlannerEvent.model_validate({**data, "event": event})
        await self.client.publish(PLANNER_EVENTS, message, qos=QOS_STREAM, disposable=True)

    # -- records -----------------------------------------------------------------------------
    def get(self, mission_id: str) -> MissionRecord:
        record = self.missions.get(mission_id)
        if record is None:
            raise NotFound(f"no mission {mission_id!r}")
        return record

    async def save(self, record: MissionRecord) -> None:
        self._dirty.discard(record.mission_id)
        await self.store.save(record)

    async def add(self, record: MissionRecord) -> MissionRecord:
        if record.mission_id in self.missions:
            raise Conflict(f"mission {record.mission_id!r} exists")
        self._track(record)
        await self.save(record)
        self.emit("mission", **record.summary())
        return record

    def next_leg_id(self, record: MissionRecord) -> str:
        return f"{record.mission_id}.{len(record.legs) + 1}"

    def busy_drones(self) -> set[str]:
        return {
            leg.drone_id
            for r in self.missions.values()
            if not r.terminal
            for leg in r.active_legs()
        }

    # -- sending -----------------------------------------------------------------------------
    async def send_leg(self, record: MissionRecord, leg: Leg) -> None:
        """Record the leg durably, then send it to its drone (QoS 1)."""
        if record.leg(leg.leg_id) is None:
            record.legs.append(leg)
        self._legs[leg.leg_id] = record.mission_id
        await self.save(record)
        request = MissionRequest(
            mission_id=leg.leg_id,
            steps=leg.drone_steps(record.work),
            onboard=record.options.onboard,
            fence=record.options.geofence,
            rally=record.options.rally_points,
        )
        await self.client.publish(
            topic(leg.drone_id, Channel.MISSION, Direction.IN), request, qos=QOS_COMMAND
        )
        self.emit("leg", mission_id=record.mission_id, leg_id=leg.leg_id, drone_id=leg.drone_id)

    async def stop_leg(self, leg: Leg, *, state: LegState = LegState.STOPPED) -> None:
        leg.state = state
        await self.client.publish(
            topic(leg.drone_id, Channel.MISSION, Direction.IN),
            MissionRequest(mission_id=leg.leg_id, action=MissionAction.STOP),
            qos=QOS_COMMAND,
        )

    async def stop_mission(self, mission_id: str, *, home: bool = False) -> MissionRecord:
        """Stop a mission: its drones hold where they are, or (``home``: an abort) each is sent
        a leg that replaces what it flies with a return home (RTL)."""
        async with self._lock:
            record = self.get(mission_id)
            if record.terminal:
                return record
            for leg in record.active_legs():
                if home:
                    await self.send_home(record, leg)
                else:
                    await self.stop_leg(leg)
            why = "aborted on request: its drones were sent home" if home else "stopped on request"
            await self._finish(record, MissionState.STOPPED, why)
            return record

    async def send_home(self, record: MissionRecord, leg: Leg) -> None:
        """End ``leg`` and send its drone home (RTL, then land) with a leg nothing waits for:
        the drone's part of the mission is over."""
        leg.state = LegState.STOPPED
        going = Leg(
            leg_id=self.next_leg_id(record),
            drone_id=leg.drone_id,
            role=LegRole.RECOVERY,
            prefix=list(GO_HOME),
            state=LegState.STOPPED,
        )
        await self.send_leg(record, going)

    async def abort_all(self) -> list[MissionRecord]:
        """Abort every unfinished mission (its drones sent home); the missions aborted."""
        unfinished = [r.mission_id for r in list(self.missions.values()) if not r.terminal]
        return [await self.stop_mission(mission_id, home=True) for mission_id in unfinished]

    async def pause_mission(self, mission_id: str) -> MissionRecord:
        """Ask each drone of a running mission to hold and keep its steps left (each answers
        ``paused``; the mission is then paused until resumed)."""
        async with self._lock:
            record = self.get(mission_id)
            flying = [leg for leg in record.active_legs() if not leg.paused]
            if record.terminal or record.state is MissionState.PLANNED or not flying:
                raise Conflict(f"mission {mission_id} is {record.state.value}: nothing to pause")
            await self.ask_legs(flying, MissionAction.PAUSE)
            return record

    async def resume_mission(self, mission_id: str) -> MissionRecord:
        """Ask each paused drone of a mission (taken over, or paused on request) to fly on with
        its leg (each answers ``resumed``, or ``paused`` again with why not: on the ground)."""
        async with self._lock:
            record = self.get(mission_id)
            paused = [leg for leg in record.active_legs() if leg.paused]
            if record.state is not MissionState.PAUSED or not paused:
                raise Conflict(f"mission {mission_id} is {record.state.value}, not paused")
            await self.ask_legs(paused, MissionAction.RESUME)
            return record

    async def ask_legs(self, legs: list[Leg], action: MissionAction) -> None:
        """Send each leg's drone ``action`` (pause, resume) for that leg."""
        for leg in legs:
            await self.client.publish(
                topic(leg.drone_id, Channel.MISSION, Direction.IN),
                MissionRequest(mission_id=leg.leg_id, action=action),
                qos=QOS_COMMAND,
            )

    # -- progress ----------------------------------------------------------------------------
    async def _on_progress(self, topic_name: str, payload: bytes) -> None:
        try:
            msg = parse_message(MissionProgress, payload)
            speaks_for_itself(topic_name, msg.drone_id)
        except MessageError as exc:
            self.dropped["progress"] += 1
            _throttle.log(
                logging.WARNING, "progress", "dropping progress on %s: %s", topic_name, exc
            )
            return
        mission_id = self._legs.get(msg.mission_id)
        if mission_id is None:
            return  # not one of ours (a mission sent by hand, or the demo)
        async with self._lock:
            record = self.missions[mission_id]
            leg = record.leg(msg.mission_id)
            if leg is None or record.terminal or leg.drone_id != msg.drone_id:
                return
            if reconcile.answers_a_report_request(msg):
                self.spawn(reconcile.forgotten(self, record, leg), f"forgotten:{leg.leg_id}")
                return
            if apply_progress(record, leg, msg):  # a step reported for the first time
                paths.add_point(record, leg.drone_id, msg.vehicle_time_s, msg.position)
            if note_seq(leg, msg.seq):
                self.spawn(reconcile.fill_gap(self, leg), f"gap:{leg.leg_id}")
            await self.save(record)
        data = msg.model_dump(mode="json", exclude_none=True)
        self.emit("progress", **{**data, "mission_id": mission_id, "leg_id": leg.leg_id})
        await self.after_progress(record, leg, msg)
        if msg.event is ProgressEvent.STEP and leg.active and leg.leg_id not in self._checking:
            from dronefleet.ground.planner import early

            self._checking.add(leg.leg_id)
            self.spawn(early.check(self, record, leg), f"early:{leg.leg_id}")

    async def after_progress(self, record: MissionRecord, leg: Leg, msg: MissionProgress) -> None:
        """Close the mission when nothing is left to fly, or fail it when a leg failed."""
        async with self._lock:
            if record.terminal or any(self._holds_open(record, lg) for lg in record.active_legs()):
                return
            # Every leg has ended (or its drone is lost, its work taken over): so has the mission;
            # its state follows from its legs'.
            left = remaining(record.work, record.required_indices(), set(record.done))
            if not left:
                await self._finish(record, MissionState.COMPLETED)
            elif any(lg.state is LegState.FAILED for lg in record.legs):
                failed = next(lg for lg in reversed(record.legs) if lg.state is LegState.FAILED)
                await self._finish(record, MissionState.FAILED, failed.error or "a leg failed")
            else:
                why = f"every leg ended with {len(left)} steps not flown"
                await self._finish(record, MissionState.FAILED, record.error or why)

    def _holds_open(self, record: MissionRecord, leg: Leg) -> bool:
        """Whether active ``leg`` keeps its mission open: its drone is heard, or it is lost with
        work nobody has taken over (the mission is then stalled until it is back). A lost
        drone's way out (going home, landing) holds nothing open."""
        if leg.drone_id not in self.lost:
            return True
        return not leg.role.outgoing and not record.handed_over(leg)

    async def _finish(
        self, record: MissionRecord, state: MissionState, error: str | None = None
    ) -> None:
        record.state = state
        record.ended_at = timestamp_s()
        record.error = error
        await self.save(record)
        await self.store.save_log(record.mission_id, build_log(record))
        self.emit("mission", **record.summary())
        log.info("mission %s %s", record.mission_id, state.value)

    # -- alarms ------------------------------------------------------------------------------
    async def _on_alarm(self, topic_name: str, payload: bytes) -> None:
        try:
            alarm = parse_message(Alarm, payload)
            speaks_for_itself(topic_name, alarm.drone_id)
        except MessageError as exc:
            self.dropped["alarm"] += 1
            _throttle.log(logging.WARNING, "alarm", "dropping alarm on %s: %s", topic_name, exc)
            return
        data = alarm.model_dump(mode="json", exclude_none=True)
        async with self._lock:
            record, leg = self._mission_of(alarm.drone_id, alarm.mission_id)
            if record is None or leg is None:
                self.emit("alarm", **data)
                return
            if any(a.timestamp == alarm.timestamp for a in record.alarms):
                return  # duplicate delivery
            record.alarms.append(alarm)
            index = leg.global_index(alarm.step_index) if alarm.step_index is not None else None
            if index is not None and record.work[index].get("command") == Command.VIRTUALALARM:
                record.done.setdefault(index, alarm.drone_id)
            await self.save(record)
        self.emit("alarm", **{**data, "mission_id": record.mission_id})
        from dronefleet.ground.planner import collaboration, replacement

        if alarm.level is AlarmLevel.CRITICAL and record.options.replacement:
            self.spawn(replacement.replace(self, record, leg, alarm), f"replace:{alarm.drone_id}")
        elif alarm.level is AlarmLevel.OUT_MEASURE and record.options.collaboration:
            self.spawn(collaboration.extend(self, record, leg, alarm), f"extend:{alarm.drone_id}")

    def _mission_of(
        self, drone_id: str, leg_id: str | None
    ) -> tuple[MissionRecord | None, Leg | None]:
        mission_id = self._legs.get(leg_id) if leg_id else None
        records = [self.missions[mission_id]] if mission_id else list(self.missions.values())
        for record in records:
            if record.terminal:
                continue
            leg = record.leg(leg_id) if leg_id else None
            leg = leg if leg is not None and leg.active else record.leg_of(drone_id)
            if leg is not None and leg.drone_id == drone_id:
                return record, leg
        return None, None

    # -- paths -------------------------------------------------------------------------------
    async def _on_telemetry(self, topic_name: str, payload: bytes) -> None:
        try:
            msg = parse_message(Telemetry, payload)
            speaks_for_itself(topic_name, msg.drone_id)
        except MessageError:
            return  # counted and dropped by the telemetry connector, which stores it
        fields = msg.fields
        if "battery_pct" in fields and "lat" in fields:
            self.latest[msg.drone_id] = {**fields, "vehicle_time_s": msg.vehicle_time_s}
        record, _leg = self._mission_of(msg.drone_id, None)
        if record is None:
            return
        if paths.add_point(record, msg.drone_id, msg.vehicle_time_s, paths.position_of(fields)):
            self._dirty.add(record.mission_id)

    async def _flush_paths(self) -> None:
        while True:
            await asyncio.sleep(2.0)
            for mission_id in list(self._dirty):
                with contextlib.suppress(Exception):
                    await self.save(self.missions[mission_id])
