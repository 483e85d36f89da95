"""What importing a mission file gives: a request the planner takes as it is, and what was lost.

The answer of ``POST /api/v1/missions/import``: :attr:`ImportedMission.spec` is a
:class:`~dronefleet.ground.planner.mission_spec.MissionSpec` (steps or an area, the geofence,
the rally points) that ``POST /api/v1/missions`` and ``/missions/preview`` accept unchanged, and the
planner page loads into its form; :attr:`~ImportedMission.warnings` says what the file held that
dronefleet does not fly (a DO command it has no step for, a second inclusion zone...).
"""

from __future__ import annotations

from enum import StrEnum
from typing import Any

from pydantic import BaseModel, Field, ValidationError

from dronefleet.errors import InvalidInput
from dronefleet.ground.planner.mission_spec import MissionSpec
from dronefleet.messaging.common import reason


class MissionFileError(InvalidInput, ValueError):
    """A mission file that cannot be imported; the message says what is wrong and where."""


class FileKind(StrEnum):
    PLAN = "plan"  # QGroundControl .plan (JSON)
    KML = "kml"  # Google Earth KML (XML)


class ImportedMission(BaseModel):
    kind: FileKind
    spec: MissionSpec = Field(description="what POST /api/v1/missions takes, as it is")
    home: list[float] | None = Field(
        default=None, description="the file's planned home [lat, lon, alt m AMSL], if any"
    )
    warnings: list[str] = Field(default_factory=list, description="what was not carried over")


def mission_spec(data: dict[str, Any], what: str) -> MissionSpec:
    """``data`` as a :class:`MissionSpec`, or :class:`MissionFileError` naming ``what``."""
    try:
        return MissionSpec.model_validate(data)
    except ValidationError as exc:
        raise MissionFileError(f"{what}: {reason(exc)}") from None
