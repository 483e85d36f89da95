"""Drone Controller (seed 3.3.2.2, 4.1.2): the drone's high-level control surface.

It keeps the Flight Controller Interface, the Navigation Processor, the Arming Switch and the
Mission Worker together; answers every control command of Table 4.2 on ``control/out`` with the
request's id; announces the drone with heartbeats every 5 s (vehicle time) and streams telemetry.
Bad input gets an error answer with the reason, and the controller keeps serving.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Awaitable, Callable
from typing import Any

from pydantic import ValidationError

from dronefleet.clock import monotonic
from dronefleet.drone.arming import ArmingSwitch
from dronefleet.drone.camera_trigger import CameraTrigger
from dronefleet.drone.command_watch import CommandWatch, watched_kind
from dronefleet.drone.config import DroneConfig
from dronefleet.drone.direct_commands import (
    MissionBusy,
    MissionGate,
    mind_the_mission,
    parse_with_force,
)
from dronefleet.drone.draw import FlightDraw
from dronefleet.drone.navigation import NavigationProcessor, Tolerance
from dronefleet.drone.state import flight_state, position_of
from dronefleet.errors import Failed
from dronefleet.messaging import topics
from dronefleet.messaging.client import QOS_COMMAND, QOS_STREAM, BrokerClient, BrokerUnavailable
from dronefleet.messaging.codec import MessageError, decode, decode_object
from dronefleet.messaging.commands import Command, CommandResponse, SelectableMode
from dronefleet.messaging.common import wall_time
from dronefleet.messaging.gear import GearQuery, GearRequest
from dronefleet.messaging.log_throttle import LogThrottle
from dronefleet.messaging.rpc import Requester, RequestTimeout
from dronefleet.messaging.status import (
    BatteryStatus,
    FlightParams,
    GpsStatus,
    Heartbeat,
    LinkFailsafe,
    Telemetry,
    WindStatus,
)
from dronefleet.messaging.topics import Channel, Direction
from dronefleet.vehicle.base import FcError, FlightController

log = logging.getLogger(__name__)

#: Called with each flight sample (fields, vehicle seconds).
SampleListener = Callable[[dict[str, float], float], Awaitable[None]]
_throttle = LogThrottle(
    log
)  # one line per kind per 10 s: junk on the broker must not flood the log


class CommandError(Failed):
    """A command that could not be carried out; the message is the reason sent back."""


class DroneController:
    """Serves ``<id>/control/in`` and publishes heartbeats and telemetry."""

    def __init__(self, config: DroneConfig, client: BrokerClient, fc: FlightController) -> None:
        self.config = config
        self.drone_id = config.drone_id
        self.client = client
        self.fc = fc
        self.clock = fc.clock
        self.navigation = NavigationProcessor(
            fc,
            takeoff_altitude_m=config.takeoff_altitude_m,
            max_altitude_m=config.max_altitude_m,
            tolerance=Tolerance(config.horizontal_tolerance_m, config.vertical_tolerance_m),
        )
        self.arming = ArmingSwitch(fc, self._event, self.navigation.modes)
        self.requester = Requester(client)
        self.camera_trigger = CameraTrigger(fc, lambda: self.gear(GearQuery.CAPTURE))
        self.mission_id: str | None = None
        self.step_index: int | None = None
        # The Mission Worker, which says whether a mission flies the vehicle: direct commands
        # that would fight it are refused, safety ones pause it (drone/direct_commands.py).
        self.missions: MissionGate | None = None
        self._tasks: list[asyncio.Task[None]] = []
        self._telemetry_task: asyncio.Task[None] | None = None
        self._sample_listeners: list[SampleListener] = []
        self.draw = FlightDraw()  # measured in flight, sampled with every heartbeat
        self._events: list[Any] = []  # listeners of local events (the Logger)
        # A direct move is reported again when it has ended (drone/command_watch.py).
        self.watch = CommandWatch(self.navigation, self._report_done)
        # A heartbeat goes at once when the flight state or the mode changes (landed, disarmed,
        # switched to RTL), not up to an interval later: the ground's picture of the vehicle
        # (REST, the fleet page, the planner's idle check) follows within one telemetry sample.
        self._told: tuple[str, str] | None = None
        self._beat_now = asyncio.Event()

    def topic(self, channel: Channel, direction: Direction = Direction.OUT) -> str:
        return topics.topic(self.drone_id, channel, direction)

    # -- lifecycle ---------------------------------------------------------------------------
    async def start(self) -> None:
        await self.client.subscribe(self.topic(Channel.CONTROL, Direction.IN), self._on_control)
        self._tasks.append(asyncio.create_task(self._heartbeats(), name="heartbeats"))
        self._telemetry_task = asyncio.create_task(self._telemetry(), name="telemetry")

    async def stop(self) -> None:
        tasks = [*self._tasks, *([self._telemetry_task] if self._telemetry_task else [])]
        for task in tasks:
            task.cancel()
        for task in tasks:
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
        self._tasks.clear()
        self._telemetry_task = None
        await self.watch.close()
        await self.camera_trigger.stop()

    def add_event_listener(self, listener: Any) -> None:
        self._events.append(listener)

    def add_sample_listener(self, listener: SampleListener) -> None:
        """Give ``listener`` every flight sample as the autopilot reports it (before the
        broker's rate limit): the fail-safe trusts the autopilot, not the broker (issue 12)."""
        self._sample_listeners.append(listener)

    async def _tell_listeners(self, sample: dict[str, float]) -> None:
        for listener in self._sample_listeners:
            try:
                await listener(sample, self.clock.now())
            except Exception:
                log.exception("%s: a flight-sample listener failed", self.drone_id)

    def _event(self, kind: str, **data: Any) -> None:
        for listener in self._events:
            with contextlib.suppress(Exception):
                listener(kind, vehicle_time_s=self.clock.now(), **data)

    # -- control/in --------------------------------------------------------------------------
    async def _on_control(self, _topic: str, payload: bytes) -> None:
        request_id, command = _ids_of(payload)
        try:
            request, forced = parse_with_force(decode_object(payload))
        except MessageError as exc:
            _throttle.log(
                logging.INFO, "control", "%s: rejected control message: %s", self.drone_id, exc
            )
            await self._respond(request_id, command, ok=False, error=str(exc))
            return
        try:
            await mind_the_mission(self.missions, self.drone_id, request, forced)
            result = await self.execute(request)
        except MissionBusy as exc:
            self._event("refused", command=str(request.command), reason=str(exc))
            await self._respond(
                request_id,
                command,
                ok=False,
                error=str(exc),
                result={"mission": exc.mission.fields()},
            )
        except (CommandError, FcError) as exc:
            await self._respond(request_id, command, ok=False, error=str(exc))
        except Exception as exc:  # an unexpected fault must not take the controller down
            log.exception("%s: %s failed", self.drone_id, command)
            await self._respond(request_id, command, ok=False, error=f"internal error: {exc}")
        else:
            kind = watched_kind(request)
            if kind is None or not isinstance(request_id, str):
                await self._respond(request_id, command, ok=True, result=result, done=True)
                return
            await self._respond(request_id, command, ok=True, result=result, done=False)
            self.watch.watch(request_id, str(command), kind)

    async def _report_done(
        self, request_id: str, command: str, ok: bool, outcome: str, result: dict[str, Any]
    ) -> None:
        """A watched move has ended: the same request id again, with how it ended."""
        error = None if ok else f"{command} {outcome}"
        try:
            await self._respond(
                request_id, command, ok=ok, done=True, outcome=outcome, result=result, error=error
            )
        except Exception:
            log.exception("%s: the end of %s was not reported", self.drone_id, command)

    async def _respond(self, request_id: Any, command: Any, **fields: Any) -> None:
        response = CommandResponse(
            request_id=request_id if isinstance(request_id, str) else None,
            drone_id=self.drone_id,
            command=command if isinstance(command, str) else None,
            vehicle_time_s=round(self.clock.now(), 3),
            **fields,
        )
        await self.client.publish(self.topic(Channel.CONTROL), response, qos=QOS_COMMAND)

    # -- the commands ------------------------------------------------------------------------
    async def execute(self, request: Any) -> dict[str, Any]:
        """Carry out one control command (also used by the Mission Worker for its steps)."""
        nav = self.navigation
        self._event("command", command=str(request.command))
        match request.command:
            case Command.ARM:
                return await self.arming.arm()
            case Command.DISARM:
                return await self.arming.disarm(force=request.force)
            case Command.TAKEOFF:
                return _target(self.fc.home(), await nav.takeoff(request.value))
            case Command.LAND:
                await nav.land()
                return {"landing": True}
            case Command.RTL:
                return await self._return_to_launch(rally=request.rally)
            case Command.MODE:
                return await self._set_mode(SelectableMode(request.value))
            case Command.NAVIGATE:
                return _target(
                    self.fc.home(),
                    await nav.navigate(request.lat, request.lon, request.altitude_delta),
                )
            case Command.CHANGE_N | Command.CHANGE_E | Command.ALTITUDE:
                return await self._change(request)
            case Command.OBJREQUEST:
                return {
                    "object": request.value,
                    "data": await self.fc.request_object(request.value),
                }
            case Command.TAKEPIC:
                return await self.gear(GearQuery.CAPTURE)
            case Command.RESETFC:
                if self.fc.state().in_air and not request.force:
                    raise CommandError("refusing to reboot the flight controller in flight")
                await self.fc.reboot(force=request.force)
                return {"rebooted": True}
            case Command.REBUILDTELEMETRY:
                await self.fc.rebuild_telemetry()
                self._restart_telemetry()
                return {"telemetry": "rebuilt"}
        raise CommandError(f"command {request.command!r} is not handled by the Drone Controller")

    async def _change(self, request: Any) -> dict[str, Any]:
        """changeN, changeE, altitude: a move relative to the current goal."""
        axis = {Command.CHANGE_N: "north_m", Command.CHANGE_E: "east_m", Command.ALTITUDE: "up_m"}
        target = await self.navigation.change(**{axis[request.command]: request.value})
        return _target(self.fc.home(), target)

    async def _return_to_launch(self, *, rally: bool) -> dict[str, Any]:
        where = await self.navigation.return_to_launch(rally=rally)
        home = self.fc.home()
        return {
            "returning": True,
            "home": {"lat": home.lat, "lon": home.lon},
            "lands_at": {"lat": where.lat, "lon": where.lon},  # a rally point, or home
        }

    async def _set_mode(self, mode: SelectableMode) -> dict[str, Any]:
        """The operator's mode selector: each mode as the Navigation Processor flies it."""
        nav = self.navigation
        match mode:
            case SelectableMode.HOLD:
                return {
                    "mode": mode.value,
                    "holding_at": _target(self.fc.home(), await nav.hold())["target"],
                }
            case SelectableMode.LAND:
                await nav.land()
                return {"mode": mode.value, "landing": True}
            case SelectableMode.RTL:
                return {"mode": mode.value, **await self._return_to_launch(rally=False)}
        if not self.fc.state().in_air:
            raise CommandError("GUIDED flies on to a goal in the air: take off first")
        goal = nav.goal if nav.goal is not None and not nav.landing else self.fc.position()
        height_m = max(goal.alt_m - self.fc.home().alt_m, 0.0)
        return {
            "mode": mode.value,
            **_target(self.fc.home(), await nav.navigate(goal.lat, goal.lon, height_m)),
        }

    async def gear(self, query: GearQuery, sensor: str | None = None) -> dict[str, Any]:
        """Ask the Gear Manager over the broker (gear/in → gear/out)."""
        try:
            reply = await self.requester.request(
                self.topic(Channel.GEAR, Direction.IN),
                self.topic(Channel.GEAR, Direction.OUT),
                GearRequest(query=query, sensor=sensor),
                timeout_s=self.config.gear_timeout_s,
            )
        except (RequestTimeout, BrokerUnavailable) as exc:
            raise CommandError(f"the Gear Manager did not answer: {exc}") from exc
        if not reply.get("ok"):
            raise CommandError(reply.get("error") or f"gear {query} failed")
        return {
            k: v for k, v in reply.items() if k in {"capture", "reading", "specs", "sensors"} and v
        }

    # -- heartbeats and telemetry ------------------------------------------------------------
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
            mission_id=self.mission_id,
            step_index=self.step_index,
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
        topic_name = self.topic(Channel.HEARTBEATS)
        while True:
            try:
                await self.client.publish(
                    topic_name, self.heartbeat(), qos=QOS_STREAM, disposable=True
                )
            except Exception:
                log.exception("%s: heartbeat failed", self.drone_id)
            await self._until_next_beat()

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

    def _note_state(self) -> None:
        """Wake the heartbeat loop when the flight state or the mode differs from the last beat."""
        if self._told is None:
            return
        state = self.fc.state()
        if (flight_state(state), str(state.mode)) != self._told:
            self._beat_now.set()

    async def _telemetry(self) -> None:
        topic_name = self.topic(Channel.TELEMETRY)
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
            await self.client.publish(topic_name, message, qos=QOS_STREAM, disposable=True)

    def _goal_fields(self) -> dict[str, float]:
        """Where the drone is flying to, while it has a goal (not landing): the ground's
        separation monitor expects it to stop there (ground/courses.py)."""
        nav = self.navigation
        if nav.goal is None or nav.landing:
            return {}
        return {"goal_lat": nav.goal.lat, "goal_lon": nav.goal.lon, "goal_alt_m": nav.goal.alt_m}

    def _restart_telemetry(self) -> None:
        if self._telemetry_task is not None:
            self._telemetry_task.cancel()
        self._telemetry_task = asyncio.create_task(self._telemetry(), name="telemetry")


def _target(home: Any, target: Any) -> dict[str, Any]:
    """A position target: ``alt_m`` above mean sea level, as the autopilot flies it, and
    ``above_home_m``, the height an operator asked for (issue 29: "alt_m: 20" read as 20 m up)."""
    return {
        "target": {
            "lat": target.lat,
            "lon": target.lon,
            "alt_m": round(target.alt_m, 3),
            "above_home_m": round(target.alt_m - home.alt_m, 3),
        }
    }


def _ids_of(payload: bytes) -> tuple[Any, Any]:
    """Best-effort request id and command of a message that may be malformed."""
    try:
        data = decode(payload)
    except MessageError:
        return None, None
    if isinstance(data, dict):
        return data.get("request_id"), data.get("command")
    return None, None
