"""Drone Controller (seed 3.3.2.2, 4.1.2): the drone's high-level control surface.

It keeps the Flight Controller Interface, the Navigation Processor, the Arming Switch and the
Mission Worker together; answers every control command of Table 4.2 on ``control/out`` with the
request's id; announces the drone with heartbeats and streams telemetry (drone/status_stream.py).
Bad input gets an error answer with the reason, and the controller keeps serving.
"""

from __future__ import annotations

import contextlib
import logging
from typing import Any

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
from dronefleet.drone.navigation import NavigationProcessor, Tolerance
from dronefleet.drone.status_stream import SampleListener, StatusStream
from dronefleet.errors import Failed
from dronefleet.messaging import topics
from dronefleet.messaging.client import QOS_COMMAND, BrokerClient, BrokerUnavailable
from dronefleet.messaging.codec import MessageError, decode, decode_object
from dronefleet.messaging.commands import Command, CommandResponse, SelectableMode
from dronefleet.messaging.gear import GearQuery, GearRequest
from dronefleet.messaging.log_throttle import LogThrottle
from dronefleet.messaging.rpc import Requester, RequestTimeout
from dronefleet.messaging.topics import Channel, Direction
from dronefleet.vehicle.base import FcError, FlightController

log = logging.getLogger(__name__)

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
        self._events: list[Any] = []  # listeners of local events (the Logger)
        # A direct move is reported again when it has ended (drone/command_watch.py).
        self.watch = CommandWatch(self.navigation, self._report_done)
        self.status = StatusStream(self)  # heartbeats and telemetry

    def topic(self, channel: Channel, direction: Direction = Direction.OUT) -> str:
        return topics.topic(self.drone_id, channel, direction)

    # -- lifecycle ---------------------------------------------------------------------------
    async def start(self) -> None:
        await self.client.subscribe(self.topic(Channel.CONTROL, Direction.IN), self._on_control)
        self.status.start()

    async def stop(self) -> None:
        await self.status.stop()
        await self.watch.close()
        await self.camera_trigger.stop()

    def add_event_listener(self, listener: Any) -> None:
        self._events.append(listener)

    def add_sample_listener(self, listener: SampleListener) -> None:
        """Give ``listener`` every flight sample as the autopilot reports it (before the
        broker's rate limit): the fail-safe trusts the autopilot, not the broker (issue 12)."""
        self.status.add_sample_listener(listener)

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
                self.status.restart_telemetry()
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
