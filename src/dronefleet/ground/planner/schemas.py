"""What the Mission Planner's REST routes answer, as models, so the OpenAPI schema says it.

The routes build plain dicts (:meth:`MissionRecord.summary`, :func:`launch.preview`); FastAPI
validates them against these on the way out, so a drift between the two is a test failure, not
a published schema that lies.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict

__all__ = ["LatLon", "MissionDetail", "MissionSummary", "Preview"]

from dronefleet.ground.planner.coverage import AreaSpec
from dronefleet.ground.planner.ends import EndAction
from dronefleet.ground.planner.models import Expansion, Handover, LatLon, Leg, MissionState
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
    notes: list[str]


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
    angle_deg: float | None
    spacing_m: float | None
    end_action: EndAction
    drones: list[DroneShare]
