"""The drone's announcements (seed 4.1.2): heartbeats on ``heartbeats/out`` and telemetry on
``telemetry/out``, for the Drone Controller.

A heartbeat goes every interval of vehicle time, and at once when the flight state or the mode
changes (landed, disarmed, switched to RTL), not up to an interval later: the ground's picture of
the vehicle (REST, the fleet page, the planner's idle check) follows within one telemetry sample.
Telemetry goes at the autopilot's rate, capped in wall time; every sample is first handed to the
drone's own listeners (fail-safe, battery guard, fence guard), before the cap.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Awaitable, Callable
from typing import TYPE_CHECKING, Any

from pydantic import ValidationError

from dronefleet.clock import monotonic
from dronefleet.drone.draw import FlightDraw
from dronefleet.drone.state import flight_state, position_of
from dronefleet.messaging.client import QOS_STREAM
from dronefleet.messaging.common import wall_time
from dronefleet.messaging.status import (
    BatteryStatus,
    FlightParams,
    GpsStatus,
    Heartbeat,
    LinkFailsafe,
    Telemetry,
    WindStatus,
)
from dronefleet.messaging.topics import Channel

if TYPE_CHECKING:
    from dronefleet.drone.controller import DroneController

log = logging.getLogger(__name__)

#: Called with each flight sample (fields, vehicle seconds).
SampleListener = Callable[[dict[str, float], float], Awaitable[None]]


class StatusStream:
    """Heartbeats and telemetry of one drone; its mission and step are the controller's."""

    def __init__(self, controller: DroneController) -> None:
        self.controller = controller
        self.drone_id = controller.drone_id
        self.fc = controller.fc
        self.clock = controller.clock
        self.config = controller.config
        self.draw = FlightDraw()  # measured in flight, sampled with every heartbeat
        self._listeners: list[SampleListener] = []
        self._heartbeat_task: asyncio.Task[None] | None = None
        self._telemetry_task: asyncio.Task[None] | None = None
        self._told: tuple[str, str] | None = None  # flight state and mode of the last beat
        self._beat_now = asyncio.Event()

    def start(self) -> None:
        self._heartbeat_task = asyncio.create_task(self._heartbeats(), name="heartbeats")
        self._telemetry_task = asyncio.create_task(self._telemetry(), name="telemetry")

    async def stop(self) -> None:
        tasks = [t for t in (self._heartbeat_task, self._telemetry_task) if t is not None]
        for task in tasks:
            task.cancel()
        for task in tasks:
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
        self._heartbeat_task = self._telemetry_task = None

    def restart_telemetry(self) -> None:
        """After the autopilot's telemetry was rebuilt: read its new stream."""
        if self._telemetry_task is not None:
            self._telemetry_task.cancel()
        self._telemetry_task = asyncio.create_task(self._telemetry(), name="telemetry")

    def add_sample_listener(self, listener: SampleListener) -> None:
        self._listeners.append(listener)

    # -- heartbeats --------------------------------------------------------------------------
    def heartbeat(self) -> Heartbeat:
        battery = self.fc.battery()
        state = self.fc.state()
        self._told = (flight_state(state), str(state.mode))
        return Heartbeat(
            drone_id=self.drone_id,
            vehicle_time_s=round(self.clock.now(), 3),
            interval_s=self.config.heartbeat_interval_s,
            position=position_of(self.fc.position(), self.fc.home()),
            home=position_of(self.fc.home(), self.fc.home()),
            battery=BatteryStatus(
                remaining_pct=max(0.0, min(100.0, battery.remaining_pct)),
                voltage_v=max(0.0, battery.voltage_v),
                current_a=battery.current_a,
                consumed_mah=battery.consumed_mah,
            ),
            state=flight_state(state),
            mode=str(state.mode),
            mission_id=self.controller.mission_id,
            step_index=self.controller.step_index,
            # A companion computer outlives its autopilot link (issue 17): the ground is told.
            autopilot_link=bool(getattr(self.fc, "connected", True)),
            flight=self._flight_params(battery, state.in_air),
            ground_speed_mps=round(self.fc.velocity().horizontal_m, 2),
            **self._navigation_status(),
        )

    def _navigation_status(self) -> dict[str, Any]:
        """GPS fix and wind, for the ground's pre-flight checks: only what the backend reports
        (a backend without a wind estimate sends none, and the ground says "unknown")."""
        status: dict[str, Any] = {}
        if (read_gps := getattr(self.fc, "gps", None)) is not None:
            gps = read_gps()
            status["gps"] = GpsStatus(fix=gps.fix, satellites=gps.satellites, hdop=gps.hdop)
        if (read_wind := getattr(self.fc, "wind", None)) is not None and (wind := read_wind()):
            status["wind"] = WindStatus(
                speed_mps=round(wind.speed_mps, 2), from_deg=round(wind.from_deg % 360.0, 1)
            )
        # What the autopilot does if this software dies (issue 26): checked before a flight.
        if (failsafe := getattr(self.fc, "link_failsafe", None)) is not None:
            status["link_failsafe"] = LinkFailsafe(
                action=failsafe.action,
                timeout_s=failsafe.timeout_s,
                set_by_drone=failsafe.set_by_drone,
            )
        return status

    def _flight_params(self, battery: Any, in_air: bool) -> FlightParams | None:
        """The vehicle's figures for the planner, with the current it draws in flight measured
        here (drone/draw.py)."""
        self.draw.sample(self.clock.now(), battery.consumed_mah, battery.current_a, in_air)
        read = getattr(self.fc, "flight_params", None)
        params = dict(read()) if read is not None else {}
        if "hover_current_a" not in params and (mean_a := self.draw.mean_a) is not None:
            params["flight_current_a"] = round(mean_a, 2)
        try:
            return FlightParams(**params) if params else None
        except ValidationError as exc:  # a figure out of range is left out, not all of them
            bad = {str(e["loc"][0]) for e in exc.errors() if e.get("loc")}
            kept = {k: v for k, v in params.items() if k not in bad}
            try:
                return FlightParams(**kept) if kept else None
            except ValidationError:
                return None

    async def _heartbeats(self) -> None:
        while True:
            await self._beat()
            await self._until_next_beat()

    async def _beat(self) -> None:
        """Publish a heartbeat now (a failure is logged: the next one is due anyway)."""
        try:
            await self.controller.client.publish(
                self.controller.topic(Channel.HEARTBEATS),
                self.heartbeat(),
                qos=QOS_STREAM,
                disposable=True,
            )
        except Exception:
            log.exception("%s: heartbeat failed", self.drone_id)

    def _state_changed(self) -> bool:
        """Whether the flight state or the mode differs from the last heartbeat's."""
        if self._told is None:
            return False
        state = self.fc.state()
        return (flight_state(state), str(state.mode)) != self._told

    async def _until_next_beat(self) -> None:
        """One heartbeat interval (vehicle seconds), or less when the state changes meanwhile.
        Extra beats do not disturb the ground's liveness: it reads the drone's rate from the
        beats' own stamps, never from how often they come (ground/fleet.py)."""
        self._beat_now.clear()
        interval = asyncio.ensure_future(self.clock.sleep(self.config.heartbeat_interval_s))
        changed = asyncio.ensure_future(self._beat_now.wait())
        try:
            await asyncio.wait({interval, changed}, return_when=asyncio.FIRST_COMPLETED)
        finally:
            for waiter in (interval, changed):
                waiter.cancel()

    async def tell_state(self) -> None:
        """A heartbeat now if the flight state or the mode differs from the last one's. Called
        before each mission report: the report that a landing ended a leg follows the heartbeat
        that says the drone is down and disarmed, on the same link, so the ground never shows a
        mission completed by a drone it still believes armed (CI: a copter read ``armed`` right
        after its mission completed, the heartbeat's wake-up one telemetry sample behind)."""
        if self._state_changed():
            await self._beat()

    def _note_state(self) -> None:
        """Wake the heartbeat loop when the flight state or the mode differs from the last beat."""
        if self._state_changed():
            self._beat_now.set()

    # -- telemetry ---------------------------------------------------------------------------
    async def _tell_listeners(self, sample: dict[str, float]) -> None:
        for listener in self._listeners:
            try:
                await listener(sample, self.clock.now())
            except Exception:
                log.exception("%s: a flight-sample listener failed", self.drone_id)

    async def _telemetry(self) -> None:
        topic_name = self.controller.topic(Channel.TELEMETRY)
        min_gap_s = 1.0 / self.config.telemetry_max_wall_hz
        last = 0.0
        async for sample in self.fc.telemetry():
            await self._tell_listeners(sample)
            self._note_state()
            now = monotonic()
            if now - last < min_gap_s:
                continue
            last = now
            fields = {**sample, **self._goal_fields()}
            vehicle_time_s = round(self.clock.now(), 3)
            message: Telemetry | dict[str, Any]
            if all(type(value) is float for value in fields.values()):
                # What Telemetry(...) would send, byte for byte, without validating per sample
                # what is already valid (the drone id was checked when the controller was made).
                message = {
                    "drone_id": self.drone_id,
                    "timestamp": wall_time(),
                    "vehicle_time_s": vehicle_time_s,
                    "fields": fields,
                }
            else:
                message = Telemetry(
                    drone_id=self.drone_id, vehicle_time_s=vehicle_time_s, fields=fields
                )
            await self.controller.client.publish(
                topic_name, message, qos=QOS_STREAM, disposable=True
            )

    def _goal_fields(self) -> dict[str, float]:
        """Where the drone is flying to, while it has a goal (not landing): the ground's
        separation monitor expects it to stop there (ground/courses.py)."""
        nav = self.controller.navigation
        if nav.goal is None or nav.landing:
            return {}
        return {"goal_lat": nav.goal.lat, "goal_lon": nav.goal.lon, "goal_alt_m": nav.goal.alt_m}
