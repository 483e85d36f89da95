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
from typing import Any

from pydantic import BaseModel, ConfigDict, Field


class MissionState(StrEnum):
    PLANNED = "planned"
    RUNNING = "running"
    PAUSED = "paused"
    HANDED_OVER = "handed_over"  # running, after at least one replacement
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


class Leg(BaseModel):
    model_config = ConfigDict(extra="ignore")

    leg_id: str
    drone_id: str
    role: str = "primary"  # primary | replacement | collaborator
    prefix: list[dict[str, Any]] = Field(default_factory=list)
    indices: list[int] = Field(default_factory=list)  # global work-step indices, in flight order
    suffix: list[dict[str, Any]] = Field(default_factory=list)  # after the work (e.g. land)
    state: LegState = LegState.SENT
    sent_at: float = Field(default_factory=time.time)
    started_vehicle_s: float | None = None
    ended_vehicle_s: float | None = None
    reports: list[StepReport] = Field(default_factory=list)
    error: str | None = None

    def drone_steps(self, work: list[dict[str, Any]]) -> list[dict[str, Any]]:
        return [*self.prefix, *(work[i] for i in self.indices), *self.suffix]

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
    area: dict[str, Any] | None = None  # the AreaSpec, for extension (extensibility parameters)
    work: list[dict[str, Any]] = Field(default_factory=list)  # the work steps, global indices
    done: dict[int, str] = Field(default_factory=dict)  # global index -> drone that did it
    required: list[int] | None = None  # indices that must be done (None: all); an extension
    # supersedes the unflown part of the area it grew from
    legs: list[Leg] = Field(default_factory=list)
    alarms: list[dict[str, Any]] = Field(default_factory=list)
    handovers: list[dict[str, Any]] = Field(default_factory=list)
    expansions: list[dict[str, Any]] = Field(default_factory=list)
    options: dict[str, Any] = Field(default_factory=dict)
    paths: dict[str, list[list[float]]] = Field(
        default_factory=dict, description="per drone: [vehicle s, lat, lon, height above home]"
    )
    error: str | None = None

    def leg(self, leg_id: str) -> Leg | None:
        return next((leg for leg in self.legs if leg.leg_id == leg_id), None)

    def active_legs(self) -> list[Leg]:
        return [leg for leg in self.legs if leg.active]

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
            if s.get("command") == "wait_for_flight" and i in required
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
