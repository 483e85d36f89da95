"""What the Mission Planner keeps about a mission (seed Figure 4.25), durably.

A mission is a list of *work* steps with global indices. It is flown in *legs*: one leg per drone
taking part, each a mission sent to that drone (its ``leg_id`` is the drone-side mission id) made
of a preparation prefix (arm, take off, go to the resume point) and a slice of the work steps. A
replacement ends one leg and starts another with the steps not yet flown; a collaborative
extension ends the legs and starts new ones over the grown area.
"""

from __future__ import annotations

import time
from enum import StrEnum
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Field

from dronefleet.ground.planner.coverage import AreaSpec
from dronefleet.ground.planner.options import LegRole, RecordOptions
from dronefleet.messaging.commands import Command
from dronefleet.messaging.status import Alarm


class MissionState(StrEnum):
    PLANNED = "planned"
    RUNNING = "running"
    PAUSED = "paused"  # a drone was taken over (drone/takeover.py): see ``error``; resumable
    HANDED_OVER = "handed_over"  # running, after at least one replacement
    STALLED = "stalled"  # cannot progress (a drone lost and nobody to take over): see ``error``
    COMPLETED = "completed"
    FAILED = "failed"
    STOPPED = "stopped"


TERMINAL = frozenset({MissionState.COMPLETED, MissionState.FAILED, MissionState.STOPPED})


class LegState(StrEnum):
    SENT = "sent"
    RUNNING = "running"
    COMPLETED = "completed"
    FAILED = "failed"
    STOPPED = "stopped"
    REPLACED = "replaced"  # ended by a handover or an extension


_COMMANDS = frozenset(c.value for c in Command)


def _a_step(step: dict[str, Any]) -> dict[str, Any]:
    """A work step is kept as the JSON object the drones get (what planning and estimates read
    fastest). Steps are validated whole by the shared step models (``parse_step``,
    messaging/commands.py) where they enter: a request's steps in ``mission_spec.work_of``,
    generated ones by construction. A record checks only the command, which costs 1/20 of a full
    check (a 10,000-step record: 6 ms instead of 120 ms, on the event loop)."""
    if step.get("command") not in _COMMANDS:
        raise ValueError(f"unknown mission step command {step.get('command')!r}")
    return step


#: One work step: a mission step (seed Table 4.3) as its JSON object, checked against its model.
WorkStep = Annotated[dict[str, Any], AfterValidator(_a_step)]


class LatLon(BaseModel):
    lat: float
    lon: float


class HandoverKind(StrEnum):
    ON_ALARM = "on alarm"  # after a CRITICAL alarm (seed 3.1.5)
    EARLY = "early"  # before the battery runs out (ours: ground/planner/early.py)


class Handover(BaseModel):
    """One drone's work handed to another (ground/planner/replacement.py, early.py)."""

    model_config = ConfigDict(extra="ignore")

    kind: HandoverKind
    from_drone: str
    from_leg: str
    reason: str
    resume_position: LatLon | None = None
    resume_index: int | None = None  # the first global step index handed over
    remaining_steps: int = 0
    to_drone: str | None = None  # None: nobody could take over (see ``error``)
    to_leg: str | None = None
    leaving_leg: str | None = None  # early: the leg the outgoing drone still flies
    alarm_vehicle_s: float | None = None
    leave_vehicle_s: float | None = None
    launch_vehicle_s: float | None = None
    predicted_old_s: float | None = None  # early: the outgoing drone's flight time left
    predicted_new_s: float | None = None  # early: the incoming drone's time to get there
    error: str | None = None
    # On alarm: the leg that takes the failing drone out, sent as the handover is decided; the
    # replacement is chosen once the drone has accepted it (its reports of the leg it flew are
    # all in by then) or after replacement.ASSIGN_WAIT_S.
    recovery_leg: str | None = None
    # A lost drone's work (ground/planner/lost.py) is taken over only once its replacement has
    # started on it: until then (False) the drone, heard again, keeps its leg and the takeover is
    # cancelled; when it happens (True) the lost drone is sent ``recovery``.
    committed: bool = True
    recovery: list[WorkStep] = Field(default_factory=list)
    cancelled: str | None = None  # why a takeover was called off (kept in ``takeovers_cancelled``)


class Expansion(BaseModel):
    """The area grown around an OUT_MEASURE alarm (ground/planner/collaboration.py)."""

    model_config = ConfigDict(extra="ignore")

    drone_id: str  # the drone that measured it
    alarm_vehicle_s: float | None = None
    centre: LatLon
    error: str | None = None
    area_factor: float | None = None
    joined: list[str] = Field(default_factory=list)
    waypoints: int | None = None
    area_m2: float | None = None
    assignments: dict[str, int] = Field(default_factory=dict)  # drone -> waypoints


class EventKind(StrEnum):
    """What a mission's timeline says happened (ground/planner/timeline.py)."""

    STARTED = "started"
    ALARM = "alarm"  # a CRITICAL or OUT_MEASURE alarm, and what was (not) done about it
    HANDOVER = "handover"  # a drone's work taken over by another (replacement)
    EXPANSION = "expansion"  # the area grown and drones called (collaboration)
    PAUSED = "paused"
    RESUMED = "resumed"
    STALLED = "stalled"
    RUNNING = "running"  # running again after a stall
    COMPLETED = "completed"
    FAILED = "failed"
    STOPPED = "stopped"


class MissionEvent(BaseModel):
    """One entry of a mission's timeline: when (the ground's clock), what, which drone, and a
    sentence an operator reads."""

    model_config = ConfigDict(extra="ignore")

    at: float | None
    kind: EventKind
    drone_id: str | None = None
    text: str
    drones: list[str] = Field(default_factory=list)  # the drones called or taking over


class StepReport(BaseModel):
    """One step a drone reported done (``index`` is global; None for preparation steps)."""

    model_config = ConfigDict(extra="ignore")

    index: int | None
    drone_step: int
    command: str
    ok: bool = True
    error: str | None = None
    position: dict[str, Any] | None = None
    started_s: float | None = None
    duration_s: float | None = None
    vehicle_time_s: float | None = None
    received_at: float = Field(default_factory=time.time)
    measured: dict[str, Any] | None = None  # readings or a picture (ground/planner/measurements)


class Leg(BaseModel):
    model_config = ConfigDict(extra="ignore")

    leg_id: str
    drone_id: str
    role: LegRole = LegRole.PRIMARY
    prefix: list[WorkStep] = Field(default_factory=list)
    indices: list[int] = Field(default_factory=list)  # global work-step indices, in flight order
    suffix: list[WorkStep] = Field(default_factory=list)  # after the work (e.g. land)
    state: LegState = LegState.SENT
    sent_at: float = Field(default_factory=time.time)
    started_vehicle_s: float | None = None
    ended_vehicle_s: float | None = None
    reports: list[StepReport] = Field(default_factory=list)
    error: str | None = None
    paused: str | None = None  # who took the drone over, while its mission is paused
    seqs: list[int] = Field(default_factory=list)  # report numbers received, sorted
    # Who flies it (issue 28): on board its autopilot (AUTO), from the companion computer, or
    # None when the drone's own configuration decides (--onboard-missions); and why not on board.
    flown_by: Literal["autopilot", "companion"] | None = None
    companion_reason: str | None = None

    #: Work steps this leg flies otherwise than the mission's work, by global index: near a
    #: lost drone, on another layer (issue 26; ground/planner/deconflict/, rule 5).
    altered: dict[int, WorkStep] = Field(default_factory=dict)

    def drone_steps(self, work: list[dict[str, Any]]) -> list[dict[str, Any]]:
        steps = (self.altered.get(i, work[i]) for i in self.indices)
        return [*self.prefix, *steps, *self.suffix]

    def global_index(self, drone_step: int) -> int | None:
        k = drone_step - len(self.prefix)
        return self.indices[k] if 0 <= k < len(self.indices) else None

    @property
    def active(self) -> bool:
        return self.state in (LegState.SENT, LegState.RUNNING)


class MissionRecord(BaseModel):
    model_config = ConfigDict(extra="ignore")

    mission_id: str
    name: str = ""
    state: MissionState = MissionState.PLANNED
    created_at: float = Field(default_factory=time.time)
    started_at: float | None = None
    ended_at: float | None = None
    drones: list[str] = Field(default_factory=list)
    area: AreaSpec | None = None  # for extension (the extensibility parameters)
    work: list[WorkStep] = Field(default_factory=list)  # the work steps, global indices
    done: dict[int, str] = Field(default_factory=dict)  # global index -> drone that did it
    required: list[int] | None = None  # indices that must be done (None: all); an extension
    # supersedes the unflown part of the area it grew from
    legs: list[Leg] = Field(default_factory=list)
    alarms: list[Alarm] = Field(default_factory=list)
    handovers: list[Handover] = Field(default_factory=list)
    expansions: list[Expansion] = Field(default_factory=list)
    # Takeovers of a lost drone's work called off because it was heard again first.
    takeovers_cancelled: list[Handover] = Field(default_factory=list)
    options: RecordOptions = Field(default_factory=RecordOptions)
    # What happened, in order (ground/planner/timeline.py): pauses, alarms, handovers, ...
    events: list[MissionEvent] = Field(default_factory=list)
    paths: dict[str, list[list[float]]] = Field(
        default_factory=dict, description="per drone: [vehicle s, lat, lon, height above home]"
    )
    error: str | None = None

    def leg(self, leg_id: str) -> Leg | None:
        return next((leg for leg in self.legs if leg.leg_id == leg_id), None)

    def active_legs(self) -> list[Leg]:
        return [leg for leg in self.legs if leg.active]

    def handed_over(self, leg: Leg) -> bool:
        """Whether ``leg``'s drone has already been replaced."""
        return any(h.from_leg == leg.leg_id for h in self.handovers)

    def leg_of(self, drone_id: str) -> Leg | None:
        """The drone's active leg in this mission."""
        return next((leg for leg in self.active_legs() if leg.drone_id == drone_id), None)

    @property
    def terminal(self) -> bool:
        return self.state in TERMINAL

    def required_indices(self) -> list[int]:
        return list(range(len(self.work))) if self.required is None else self.required

    def summary(self) -> dict[str, Any]:
        required = set(self.required_indices())
        waypoints = [
            i
            for i, s in enumerate(self.work)
            if s.get("command") == Command.WAIT_FOR_FLIGHT and i in required
        ]
        return {
            "mission_id": self.mission_id,
            "name": self.name,
            "state": self.state.value,
            "drones": sorted({leg.drone_id for leg in self.legs} or set(self.drones)),
            "steps": len(self.work),
            "steps_done": len(self.done),
            "waypoints": len(waypoints),
            "waypoints_reached": sum(1 for i in waypoints if i in self.done),
            "created_at": self.created_at,
            "started_at": self.started_at,
            "ended_at": self.ended_at,
            "handovers": len(self.handovers),
            "expansions": len(self.expansions),
            "error": self.error,
        }
