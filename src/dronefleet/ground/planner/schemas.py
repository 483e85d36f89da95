"""What the Mission Planner's REST routes answer, as models, so the OpenAPI schema says it.

The routes build plain dicts (:meth:`MissionRecord.summary`, :func:`launch.preview`); FastAPI
validates them against these on the way out, so a drift between the two is a test failure, not
a published schema that lies.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict

__all__ = ["LatLon", "MissionDetail", "MissionProgressView", "MissionSummary", "Preview"]

from dronefleet.ground.planner.coverage import AreaSpec
from dronefleet.ground.planner.ends import EndAction
from dronefleet.ground.planner.models import (
    Expansion,
    Handover,
    LatLon,
    Leg,
    MissionEvent,
    MissionState,
)
from dronefleet.ground.planner.options import RecordOptions
from dronefleet.messaging.status import Alarm


class MissionSummary(BaseModel):
    mission_id: str
    name: str
    state: MissionState
    drones: list[str]
    steps: int
    steps_done: int
    waypoints: int
    waypoints_reached: int
    created_at: float
    started_at: float | None
    ended_at: float | None
    handovers: int
    expansions: int
    error: str | None


class MissionDetail(BaseModel):
    """A summary's counts and the whole record but its flown paths; where both have a field,
    the record's wins (``drones`` as planned, ``handovers`` and ``expansions`` as lists)."""

    model_config = ConfigDict(extra="allow")
    mission_id: str
    name: str
    state: MissionState
    drones: list[str]
    steps: int
    steps_done: int
    waypoints: int
    waypoints_reached: int
    created_at: float
    started_at: float | None
    ended_at: float | None
    handovers: list[Handover]
    expansions: list[Expansion]
    error: str | None
    area: AreaSpec | None
    work: list[dict[str, Any]]
    done: dict[str, str]
    required: list[int] | None
    legs: list[Leg]
    alarms: list[Alarm]
    options: RecordOptions


class DroneShare(BaseModel):
    drone_id: str
    steps: int
    #: The steps appended to end the share with the mission's end action (none for ``hold``, or
    #: when the steps end on the ground already: ground/planner/ends.py).
    end: list[str]
    duration_s: float
    battery_used_pct: float
    battery_end_pct: float
    #: Of those: the way home (its end, or the steps' own last land or RTL; 0 for ``hold``).
    return_s: float = 0.0
    return_battery_pct: float = 0.0
    #: Who flies it: on board the autopilot, from the companion computer, or (None) as the drone
    #: is configured; why not on board when it cannot be.
    flown_by: Literal["autopilot", "companion"] | None = None
    companion_reason: str | None = None
    notes: list[str]
    #: Where its work steps fly, in order (the planner map colours each drone's route).
    waypoints: list[LatLon] = []


class ReadingFeature(BaseModel):
    """One sensor reading as a GeoJSON Point feature (ground/planner/measurements.py)."""

    type: Literal["Feature"]
    geometry: dict[str, Any]
    properties: dict[str, Any]


class Readings(BaseModel):
    """What the drones measured: a GeoJSON FeatureCollection (RFC 7946)."""

    type: Literal["FeatureCollection"]
    features: list[ReadingFeature]


class Preview(BaseModel):
    steps: list[dict[str, Any]]
    waypoints: list[LatLon]
    area_m2: float | None
    angle_deg: float | None  # the swaths' bearing; None for rings and step lists
    #: How the area is flown: "swaths" (back and forth at angle_deg), "rings" (its outline
    #: flown inward) or "headland" (its outline flown once, then swaths inside); the last two
    #: only on small areas where they are quicker; None for step lists.
    pattern: Literal["swaths", "rings", "headland"] | None = None
    spacing_m: float | None
    #: What the area's coverage target left uncovered: m², and the pieces as [lat, lon] rings.
    uncovered_m2: float | None = None
    uncovered: list[list[tuple[float, float]]] = []
    end_action: EndAction
    drones: list[DroneShare]


class CurrentStep(BaseModel):
    """The step a drone flies now: its number in the drone's leg, and in the mission's work."""

    drone_step: int
    drone_steps: int
    index: int | None  # None: a step of the leg's own (arm, take off, the way home)
    command: str


class DroneProgress(BaseModel):
    drone_id: str
    role: str
    #: flying, sent, paused, leaving, handed over, done, failed, stopped
    doing: str
    steps: int  # the work steps it was given (and did)
    steps_done: int
    waypoints: int
    waypoints_reached: int
    share: float  # steps_done / steps
    current: CurrentStep | None
    paused: str | None
    #: Vehicle seconds left, estimated from where it is (ground/planner/eta.py); None: unknown.
    eta_s: float | None
    eta_pending: bool  # newer figures are on their way


class MissionProgressView(MissionSummary):
    """A mission as an operator watches it: per drone, and its timeline."""

    fraction_done: float
    eta_s: float | None  # the longest time left of its drones (vehicle seconds)
    progress: list[DroneProgress]
    events: list[MissionEvent]
