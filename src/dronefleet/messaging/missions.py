"""Missions: requests on ``<id>/mission/in`` and progress on ``<id>/mission/out``.

A mission is an ordered list of steps with the seed's command names. The seed's Mission Planner
sends it base64-encoded (``"mission": "<base64 of a JSON list>"``); plain JSON (``"steps": [...]``)
is accepted too.
"""

from __future__ import annotations

import base64
import binascii
from enum import StrEnum
from typing import Any, Literal

from pydantic import Field

from dronefleet.messaging.codec import MessageError, decode, encode
from dronefleet.messaging.commands import RequestId, parse_step
from dronefleet.messaging.common import DroneId, Message, Position, wall_time
from dronefleet.messaging.fence import MAX_RALLY_POINTS, Geofence, RallyPoint

MAX_STEPS = 10_000


class MissionAction(StrEnum):
    START = "start"
    STOP = "stop"
    REPORT = "report"  # re-send every progress report of ``mission_id`` (a planner catching up)
    PAUSE = "pause"  # hold, and keep the steps left for a resume
    RESUME = "resume"  # fly on with a mission paused by a takeover (drone/takeover.py)


class MissionRequest(Message):
    """Start a mission (replacing any running one), stop or resume it, or ask for its reports."""

    request_id: RequestId | None = None
    mission_id: str = Field(default="", max_length=128)
    action: MissionAction = MissionAction.START
    mission: str | None = Field(default=None, description="base64 of a JSON list of steps")
    steps: list[dict[str, Any]] | None = Field(default=None, max_length=MAX_STEPS)
    start_index: int = Field(default=0, ge=0, description="index of the first step's label")
    fence: Geofence | None = Field(
        default=None, description="where the drone may fly this mission (drone/fence_guard.py)"
    )
    rally: list[RallyPoint] = Field(
        default_factory=list,
        max_length=MAX_RALLY_POINTS,
        description="rally points, uploaded to a MAVLink autopilot with the fence",
    )
    onboard: bool | None = Field(
        default=None,
        description="fly on board the autopilot (true), from the companion computer (false), "
        "or as the drone is configured (null)",
    )


def encode_steps_base64(steps: list[dict[str, Any]]) -> str:
    """Encode steps the seed's way: base64 of the JSON list."""
    return base64.b64encode(encode(steps)).decode("ascii")


def decode_steps(request: MissionRequest) -> list[Any]:
    """The validated steps of a start request, from base64 or JSON; :class:`MessageError` if bad."""
    if request.mission is not None and request.steps is not None:
        raise MessageError("give either 'mission' (base64) or 'steps' (JSON), not both")
    if request.mission is not None:
        try:
            raw = base64.b64decode(request.mission, validate=True)
        except (binascii.Error, ValueError) as exc:
            raise MessageError(f"mission is not valid base64: {exc}") from exc
        data = decode(raw)
        if isinstance(data, dict) and "steps" in data:
            data = data["steps"]
    elif request.steps is not None:
        data = request.steps
    else:
        raise MessageError("a start request needs 'mission' (base64) or 'steps' (JSON)")
    if not isinstance(data, list) or not data:
        raise MessageError("a mission must be a non-empty list of steps")
    if len(data) > MAX_STEPS:
        raise MessageError(f"a mission has at most {MAX_STEPS} steps, got {len(data)}")
    steps = []
    for i, item in enumerate(data):
        try:
            steps.append(parse_step(item))
        except MessageError as exc:
            raise MessageError(f"step {i}: {exc}") from exc
    return steps


class ProgressEvent(StrEnum):
    ACCEPTED = "accepted"  # decoded and queued
    REJECTED = "rejected"  # could not be decoded: nothing changed
    STEP = "step"  # one step done
    COMPLETED = "completed"  # every step done
    STOPPED = "stopped"  # stopped on request or replaced by a new mission
    FAILED = "failed"  # a step failed; the mission ends
    PAUSED = "paused"  # someone else took the vehicle (another station, the RC, a failsafe)
    RESUMED = "resumed"  # flying the paused mission again, on request


class MissionProgress(Message):
    """One progress report from the Mission Worker."""

    drone_id: DroneId
    mission_id: str
    request_id: str | None = None
    event: ProgressEvent
    seq: int | None = Field(
        default=None,
        ge=1,
        description="the report's number in its mission, from 1: a gap shows reports missed",
    )
    step_index: int | None = None
    step_count: int | None = None
    command: str | None = None
    ok: bool = True
    error: str | None = None
    position: Position | None = None
    step_started_s: float | None = Field(default=None, description="vehicle time")
    step_duration_s: float | None = Field(default=None, description="vehicle seconds")
    decode_time_s: float | None = Field(default=None, description="wall seconds to decode")
    result: dict[str, Any] | None = None
    vehicle_time_s: float | None = None
    timestamp: float = Field(default_factory=wall_time)
    kind: Literal["progress"] = "progress"


def request_ids(payload: bytes) -> tuple[str | None, str | None]:
    """The ``request_id`` and ``mission_id`` of a ``mission/in`` payload, read before it is
    validated, so that even the rejection of a bad one names what it answers."""
    try:
        data = decode(payload)
    except MessageError:
        return None, None
    if not isinstance(data, dict):
        return None, None
    rid, mid = data.get("request_id"), data.get("mission_id")
    return (rid if isinstance(rid, str) else None, mid if isinstance(mid, str) else None)
