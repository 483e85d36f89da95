"""Mission Planner (seed 3.4.2.4, 4.2.4): missions out, progress in, drones replaced and joined.

It sends each drone its leg of a mission on ``<id>/mission/in``, follows ``+/mission/out`` and
``+/alarms/out``, and keeps every mission's state in the ground state store. Its broker session is
persistent (QoS 1), so progress and alarms published while the planner is down are delivered when
it comes back, and tracking carries on where it stopped. A CRITICAL alarm starts a replacement
(:mod:`.replacement`); an OUT_MEASURE alarm grows the area (:mod:`.collaboration`).

The reports are read in :mod:`.reports`, the alarms in :mod:`.alarms`; a mission's end is decided
and written in :mod:`.settling`; stop, abort, pause and resume of a whole mission are in
:mod:`.mission_ops`. The planner keeps the state they share, its lock and its tasks.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections import Counter
from collections.abc import Callable
from typing import Any

from dronefleet.errors import Conflict, InvalidInput, NotFound
from dronefleet.ground.planner import (
    alarms,
    mission_ops,
    paths,
    reconcile,
    reports,
    settling,
    timeline,
)
from dronefleet.ground.planner.ends import GO_HOME
from dronefleet.ground.planner.fleet_view import FleetView
from dronefleet.ground.planner.latest import LatestTelemetry
from dronefleet.ground.planner.mission_log import build_log
from dronefleet.ground.planner.models import (
    Leg,
    LegState,
    MissionRecord,
    MissionState,
)
from dronefleet.ground.planner.options import LegRole
from dronefleet.ground.planner.start_delay import StartDelays
from dronefleet.ground.planner.store import MissionStore
from dronefleet.ground.planner.worker import PlanningWorker
from dronefleet.ground.state import StateStore
from dronefleet.messaging.client import QOS_COMMAND, QOS_STREAM, BrokerClient
from dronefleet.messaging.ground_events import PlannerEvent
from dronefleet.messaging.missions import (
    MissionAction,
    MissionRequest,
)
from dronefleet.messaging.rpc import Requester
from dronefleet.messaging.status import Heartbeat, Telemetry
from dronefleet.messaging.topics import (
    IDENTIFIER_EVENTS,
    PLANNER_EVENTS,
    Channel,
    Direction,
    any_drone,
    topic,
)

log = logging.getLogger(__name__)


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
        # Heartbeats come from the ground's Fleet Inbox: a session an earlier version subscribed
        # to them (``+/heartbeats/out``) on this link is rid of that subscription.
        self.client = BrokerClient(
            broker_url, client_id, persistent_session=True, retired=(any_drone(Channel.HEARTBEATS),)
        )
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
        self.leg_missions: dict[str, str] = {}  # leg id -> mission id
        self._lock = asyncio.Lock()
        self._listeners: list[Callable[[str, dict[str, Any]], Any]] = []
        self._tasks: set[asyncio.Task[Any]] = set()
        self._dirty: set[str] = set()
        self._unwritten: set[str] = set()  # missions a write failed for (a full disk)
        self._flusher: asyncio.Task[None] | None = None
        self.latest = LatestTelemetry()  # drone id -> latest telemetry fields
        self.check_delays: dict[str, float] = {}  # early replacement's own delay
        self.start_delays = StartDelays()  # legs' send-to-start delays (start_delay.py)
        self.check_again: set[str] = set()  # a step reported while its early check ran
        self._checking: set[str] = set()  # legs whose early-replacement check is running
        self.gap_asked: dict[str, float] = {}  # leg id -> when its missing reports were asked
        self.gap_since: dict[str, float] = {}  # leg id -> when its gap first held its mission open
        self.resettling: set[str] = set()  # missions whose settling waits for a refill
        self.mismatched: dict[str, int] = {}  # drone id -> heartbeats naming another mission
        self.lost: set[str] = set()  # drones the Drone Identifier last declared lost
        self.lost_epochs: dict[str, int] = {}  # drone id -> times it was declared lost or back
        self.confirming: set[str] = set()  # legs whose drone's loss is being confirmed
        self.trimming: set[str] = set()  # replacement legs about to be cut (lost.flew_unheard)

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
        # The lock is held until what a restart interrupted is finished (reconcile.resume):
        # reports and alarms the broker kept for this session are read after, not in between
        # (issue 26: a report read first closed a mission being resumed; an alarm delivered
        # again raced the resumed handover).
        async with self._lock:
            await self.client.start(timeout_s=None)
            await self.client.subscribe(
                any_drone(Channel.MISSION), self._on_progress, qos=QOS_COMMAND
            )
            await self.client.subscribe(any_drone(Channel.ALARMS), self._on_alarm, qos=QOS_COMMAND)
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
            await reconcile.resume(self)
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
            self.leg_missions[leg.leg_id] = record.mission_id

    def add_listener(self, listener: Callable[[str, dict[str, Any]], Any]) -> None:
        """``listener(event, data)`` for every mission event (the WebSocket hub, experiments)."""
        self._listeners.append(listener)

    def emit(self, event: str, /, **data: Any) -> None:
        record = self.missions.get(str(data.get("mission_id")))
        if record is not None and timeline.note(record, event, data):
            self._dirty.add(record.mission_id)  # written within 2 s (_flush_paths)
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
        """Write ``record``; one the store could not take (a full disk) stays to be written
        again by the flusher (:meth:`_flush_paths`) until it is, and the error is raised."""
        self._dirty.add(record.mission_id)
        try:
            await self.store.save(record)
        except Exception:
            self._unwritten.add(record.mission_id)
            raise
        self._dirty.discard(record.mission_id)

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

    def mission_of(
        self, drone_id: str, leg_id: str | None
    ) -> tuple[MissionRecord | None, Leg | None]:
        """The unfinished mission and active leg a message from ``drone_id`` (about ``leg_id``,
        when it names one) is about; (None, None) when none."""
        mission_id = self.leg_missions.get(leg_id) if leg_id else None
        records = [self.missions[mission_id]] if mission_id else list(self.missions.values())
        for record in records:
            if record.terminal:
                continue
            leg = record.leg(leg_id) if leg_id else None
            leg = leg if leg is not None and leg.active else record.leg_of(drone_id)
            if leg is not None and leg.drone_id == drone_id:
                return record, leg
        return None, None

    # -- sending -----------------------------------------------------------------------------
    async def send_leg(self, record: MissionRecord, leg: Leg) -> None:
        """Record the leg durably, then send it to its drone (QoS 1)."""
        if record.leg(leg.leg_id) is None:
            record.legs.append(leg)
        self.leg_missions[leg.leg_id] = record.mission_id
        await self.save(record)
        request = MissionRequest(
            mission_id=leg.leg_id,
            steps=leg.drone_steps(record.work),
            onboard=record.options.onboard,
            fence=record.options.geofence,
            rally=record.options.rally_points,
        )
        self.start_delays.sent(
            leg.leg_id, (self.latest.get(leg.drone_id) or {}).get("vehicle_time_s")
        )
        await self.client.publish(
            topic(leg.drone_id, Channel.MISSION, Direction.IN), request, qos=QOS_COMMAND
        )
        self.emit("leg", mission_id=record.mission_id, leg_id=leg.leg_id, drone_id=leg.drone_id)

    async def stop_leg(self, leg: Leg, *, state: LegState = LegState.STOPPED) -> None:
        leg.state = state
        self.start_delays.forget(leg.leg_id)
        await self.client.publish(
            topic(leg.drone_id, Channel.MISSION, Direction.IN),
            MissionRequest(mission_id=leg.leg_id, action=MissionAction.STOP),
            qos=QOS_COMMAND,
        )

    async def stop_mission(self, mission_id: str, *, home: bool = False) -> MissionRecord:
        """Stop a mission, or abort it (``home``): mission_ops.stop_mission."""
        return await mission_ops.stop_mission(self, mission_id, home=home)

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
        """Abort every unfinished mission: mission_ops.abort_all."""
        return await mission_ops.abort_all(self)

    async def pause_mission(self, mission_id: str) -> MissionRecord:
        """Ask each drone of a running mission to hold: mission_ops.pause_mission."""
        return await mission_ops.pause_mission(self, mission_id)

    async def resume_mission(self, mission_id: str) -> MissionRecord:
        """Ask each paused drone of a mission to fly on: mission_ops.resume_mission."""
        return await mission_ops.resume_mission(self, mission_id)

    async def ask_legs(self, legs: list[Leg], action: MissionAction) -> None:
        """Send each leg's drone ``action`` (pause, resume) for that leg."""
        for leg in legs:
            await self.client.publish(
                topic(leg.drone_id, Channel.MISSION, Direction.IN),
                MissionRequest(mission_id=leg.leg_id, action=action),
                qos=QOS_COMMAND,
            )

    # -- progress and the end of a mission (reports.py, settling.py) -------------------------
    async def _on_progress(self, topic_name: str, payload: bytes) -> None:
        await reports.on_progress(self, topic_name, payload)

    async def settle_locked(self, record: MissionRecord) -> None:
        """(The lock held.) End the mission if every leg has ended: settling.settle_locked."""
        await settling.settle_locked(self, record)

    async def finish(
        self, record: MissionRecord, state: MissionState, error: str | None = None
    ) -> None:
        """End ``record`` as ``state`` (with ``error``): settling.finish."""
        await settling.finish(self, record, state, error)

    async def back_online(self, drone_id: str) -> None:
        """``drone_id`` is heard again (reconcile.back_online)."""
        await reconcile.back_online(self, drone_id)

    # -- alarms (alarms.py) ------------------------------------------------------------------
    async def _on_alarm(self, topic_name: str, payload: bytes) -> None:
        await alarms.on_alarm(self, topic_name, payload)

    async def on_heartbeat(self, beat: Heartbeat) -> None:
        """A drone's heartbeat, as the ground's Fleet Inbox read it (reconcile.on_heartbeat)."""
        await reconcile.on_heartbeat(self, beat)

    # -- paths -------------------------------------------------------------------------------
    def on_telemetry(self, msg: Telemetry) -> None:
        """A drone's telemetry, as the ground's Fleet Inbox read it (ground/inbox.py)."""
        fields = msg.fields
        if "battery_pct" in fields and "lat" in fields:
            self.latest.keep(msg.drone_id, msg.vehicle_time_s, fields)
        record, _leg = self.mission_of(msg.drone_id, None)
        if record is None:
            return
        if paths.add_point(record, msg.drone_id, msg.vehicle_time_s, paths.position_of(fields)):
            self._dirty.add(record.mission_id)

    async def _flush_paths(self) -> None:
        """Every 2 s, write the records changed since (paths, timelines) or not written when
        they changed (a full disk). A mission a write failed for is settled once written (or
        its log written, if it ended meanwhile): chaos seed 320, the disk full as the last leg
        ended, left the mission running for ever."""
        while True:
            await asyncio.sleep(2.0)
            for mission_id in list(self._dirty):
                record = self.missions[mission_id]
                with contextlib.suppress(Exception):
                    await self.save(record)
                    if mission_id not in self._unwritten:
                        continue
                    if record.terminal:  # it ended while it could not be written: its log too
                        await self.store.save_log(mission_id, build_log(record))
                    else:
                        async with self.lock:
                            await self.settle_locked(record)
                    self._unwritten.discard(mission_id)
