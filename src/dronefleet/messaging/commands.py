"""Control commands (seed Table 4.2) and mission-only commands (Table 4.3), one model each.

A control request on ``<id>/control/in`` is a flat JSON object like the seed's:
``{"request_id": "...", "command": "navigate", "lat": 40.6, "lon": -8.6, "altitude_delta": 10}``.
The answer on ``<id>/control/out`` echoes the ``request_id``.
"""

from __future__ import annotations

from enum import StrEnum
from typing import Annotated, Any, Literal

from pydantic import Field, TypeAdapter

from dronefleet.messaging.codec import MessageError
from dronefleet.messaging.common import DroneId, Message, validate, wall_time

#: Largest relative move or climb one command may ask for, in metres.
MAX_RELATIVE_MOVE_M = 5_000.0
#: Highest altitude above home a command may ask for, in metres.
MAX_ALTITUDE_M = 1_000.0


class Command(StrEnum):
    # Routed to the Drone Controller (Table 4.2).
    OBJREQUEST = "objrequest"
    CHANGE_N = "changeN"
    CHANGE_E = "changeE"
    ALTITUDE = "altitude"
    NAVIGATE = "navigate"
    LAND = "land"
    RTL = "rtl"  # return to launch: home, then land (ArduPilot's RTL; ours where there is none)
    TAKEOFF = "takeoff"
    ARM = "arm"
    DISARM = "disarm"
    TAKEPIC = "takepic"
    RESETFC = "resetfc"
    REBUILDTELEMETRY = "rebuildtelemetry"
    MODE = "mode"  # a flight mode the Drone Controller can choose (the console's selector)
    # Mission-only (Table 4.3) and our additions.
    WAIT_FOR_FLIGHT = "wait_for_flight"
    SLEEP = "sleep"
    VIRTUALALARM = "virtualalarm"
    READ_SENSORS = "read_sensors"
    CAMERA_TRIGGER = "camera_trigger"


class AlarmLevel(StrEnum):
    CRITICAL = "CRITICAL"  # the drone must be replaced
    OUT_MEASURE = "OUT_MEASURE"  # a reading outside its bounds: collaboration requested
    WARNING = "WARNING"  # look now: e.g. two drones about to come too close (ground/separation)


class SelectableMode(StrEnum):
    """The flight modes an operator may choose for a drone (``mode`` command): the ones the
    Drone Controller flies itself, on every backend. Manual modes stay with the RC pilot."""

    GUIDED = "GUIDED"  # fly on to the goal (after a Hold): refused mid-mission unless forced
    HOLD = "HOLD"  # stop and hold position: always obeyed (a mission is paused first)
    LAND = "LAND"  # land where it is: always obeyed
    RTL = "RTL"  # return to launch and land: always obeyed


RequestId = Annotated[str, Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_\-]+$")]
Metres = Annotated[float, Field(ge=-MAX_RELATIVE_MOVE_M, le=MAX_RELATIVE_MOVE_M)]


class _Request(Message):
    request_id: RequestId | None = None
    sender: str | None = Field(default=None, max_length=128)


class ObjRequest(_Request):
    command: Literal[Command.OBJREQUEST]
    value: str = Field(min_length=1, max_length=64, description="object name, e.g. GPSPosition")


class ChangeN(_Request):
    command: Literal[Command.CHANGE_N]
    value: Metres = Field(description="metres to move north (negative: south)")


class ChangeE(_Request):
    command: Literal[Command.CHANGE_E]
    value: Metres = Field(description="metres to move east (negative: west)")


class Altitude(_Request):
    command: Literal[Command.ALTITUDE]
    value: Metres = Field(description="metres to climb (negative: descend)")


class Navigate(_Request):
    command: Literal[Command.NAVIGATE]
    lat: float = Field(ge=-90, le=90)
    lon: float = Field(ge=-180, le=180)
    altitude_delta: float | None = Field(
        default=None, ge=0, le=MAX_ALTITUDE_M, description="target height above home (m)"
    )


class Land(_Request):
    command: Literal[Command.LAND]


class Rtl(_Request):
    command: Literal[Command.RTL]
    rally: bool = Field(
        default=False,
        description="land at the nearest of the mission's rally points instead, when one is "
        "nearer than home (a drone sent home early: abort, handover, lost)",
    )


class SetMode(_Request):
    """Switch the flight mode: HOLD stops and holds position, LAND lands where it is, RTL
    returns home and lands, GUIDED flies on to the goal it held at."""

    command: Literal[Command.MODE]
    # The modes as text (a Literal, not the enum): the ground's strict request bodies take JSON
    # strings, and the drone compares them with SelectableMode (a StrEnum) all the same.
    value: Literal["GUIDED", "HOLD", "LAND", "RTL"] = Field(description="the flight mode to set")


class Takeoff(_Request):
    command: Literal[Command.TAKEOFF]
    value: float | None = Field(
        default=None, gt=0, le=MAX_ALTITUDE_M, description="take-off height above home (m)"
    )


class Arm(_Request):
    command: Literal[Command.ARM]


class Disarm(_Request):
    command: Literal[Command.DISARM]
    force: bool = Field(default=False, description="disarm even in flight (the vehicle falls)")


class TakePic(_Request):
    command: Literal[Command.TAKEPIC]


class ResetFc(_Request):
    command: Literal[Command.RESETFC]
    force: bool = False


class RebuildTelemetry(_Request):
    command: Literal[Command.REBUILDTELEMETRY]


class WaitForFlight(_Request):
    command: Literal[Command.WAIT_FOR_FLIGHT]
    horizontal_tolerance_m: float | None = Field(default=None, gt=0, le=100)
    vertical_tolerance_m: float | None = Field(default=None, gt=0, le=100)
    timeout_s: float | None = Field(default=None, gt=0, le=86_400)


class Sleep(_Request):
    command: Literal[Command.SLEEP]
    value: float = Field(ge=0, le=86_400, description="seconds to hover (vehicle time)")


class VirtualAlarm(_Request):
    command: Literal[Command.VIRTUALALARM]
    level: AlarmLevel
    message: str = Field(default="", max_length=500)


class ReadSensors(_Request):
    command: Literal[Command.READ_SENSORS]
    value: float = Field(default=0, ge=0, le=3_600, description="seconds to hold while reading")


class CameraTrigger(_Request):
    """Photograph every ``value`` metres travelled, without stopping (0 turns it off)."""

    command: Literal[Command.CAMERA_TRIGGER]
    value: float = Field(ge=0, le=1_000, description="trigger distance in metres; 0 = off")


ControlRequest = Annotated[
    ObjRequest
    | ChangeN
    | ChangeE
    | Altitude
    | Navigate
    | Land
    | Rtl
    | Takeoff
    | Arm
    | Disarm
    | TakePic
    | ResetFc
    | RebuildTelemetry
    | SetMode,
    Field(discriminator="command"),
]

MissionStep = Annotated[
    ChangeN
    | ChangeE
    | Altitude
    | Navigate
    | Land
    | Rtl
    | Takeoff
    | Arm
    | Disarm
    | TakePic
    | WaitForFlight
    | Sleep
    | VirtualAlarm
    | ReadSensors
    | CameraTrigger
    | ObjRequest,
    Field(discriminator="command"),
]

CONTROL_COMMANDS = frozenset(
    {
        Command.OBJREQUEST,
        Command.CHANGE_N,
        Command.CHANGE_E,
        Command.ALTITUDE,
        Command.NAVIGATE,
        Command.LAND,
        Command.RTL,
        Command.TAKEOFF,
        Command.ARM,
        Command.DISARM,
        Command.TAKEPIC,
        Command.RESETFC,
        Command.REBUILDTELEMETRY,
        Command.MODE,
    }
)

_control_adapter: TypeAdapter[Any] = TypeAdapter(ControlRequest)
_step_adapter: TypeAdapter[Any] = TypeAdapter(MissionStep)


def _check_command(data: Any, allowed: frozenset[str], what: str) -> None:
    if not isinstance(data, dict):
        raise MessageError(f"a {what} must be a JSON object, got {type(data).__name__}")
    command = data.get("command")
    if command is None:
        raise MessageError(f"{what} has no 'command' field")
    if command not in allowed:
        known = ", ".join(sorted(allowed))
        raise MessageError(f"unknown {what} command {command!r}; known: {known}")


def parse_control(data: Any) -> Any:
    """Validate a control request; raise :class:`MessageError` with the reason."""
    _check_command(data, CONTROL_COMMANDS, "control")
    return validate(_control_adapter, data)


def parse_step(data: Any) -> Any:
    """Validate one mission step; raise :class:`MessageError` with the reason."""
    _check_command(data, frozenset(c.value for c in Command), "mission step")
    return validate(_step_adapter, data)


class CommandResponse(Message):
    """The Drone Controller's answer on ``control/out``."""

    request_id: str | None
    drone_id: DroneId
    command: str | None
    ok: bool
    error: str | None = None
    result: dict[str, Any] | None = None
    #: Whether the command is carried out. False on the answer to a move that takes time (a
    #: take-off, a goto, a landing): the drone sends the same ``request_id`` again with ``done``
    #: true once it is there, landed or holding, or with ``ok`` false when it is not
    #: (drone/command_watch.py). None: an answer from a drone that does not say.
    done: bool | None = None
    outcome: str | None = Field(
        default=None,
        max_length=40,
        description="how a move ended: reached, landed, holding, superseded, timed out",
    )
    timestamp: float = Field(default_factory=wall_time)
    vehicle_time_s: float | None = None
