"""How a mission is flown: the options a person picks (REST ``options``) and what the record keeps.

Lowest module of the planner's state: :mod:`.models` keeps :class:`RecordOptions` in every
mission record, :mod:`.launch` validates :class:`MissionOptions` in every request.
"""

from __future__ import annotations

from enum import StrEnum
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from dronefleet.ground.planner.ends import EndAction
from dronefleet.ground.planner.geofence import Geofence
from dronefleet.messaging.fence import MAX_RALLY_POINTS, RallyPoint

#: How a drone gets to its work: climbing while flying (ours) or the dissertation's way (seed).
Strategy = Literal["ours", "seed"]


class MissionOptions(BaseModel):
    model_config = ConfigDict(extra="forbid")

    replacement: bool = True  # replace a drone that raises CRITICAL
    early_replacement: bool = True  # launch the replacement before the battery runs out
    collaboration: bool = True  # grow the area on OUT_MEASURE
    collaborators: int = Field(default=2, ge=0, le=10)
    max_expansions: int = Field(default=1, ge=0, le=10)
    strategy: Strategy = "ours"
    # Fly each leg on board its autopilot (MAVLink AUTO) when its steps allow it (true), from
    # the companion computer (false), or as each drone is configured (null).
    onboard: bool | None = None
    # How each drone's share ends (ground/planner/ends.py): home and land (default), land where
    # the work ended, or hold there.
    end_action: EndAction = "rtl"
    # A steady wind the estimates fly in (issue 28): its speed and where it blows from (degrees,
    # 0 = north). Without it each drone's autopilot's wind estimate is used, else none.
    wind_mps: float | None = Field(default=None, ge=0, le=50)
    wind_from_deg: float = Field(default=0.0, ge=0, le=360)
    # Where the mission may fly: checked for every drone's share before it is accepted
    # (ground/planner/geofence.py).
    geofence: Geofence | None = None
    # Where a drone sent home early may land instead, when one is nearer than home (ground/
    # planner/rally.py); each must be inside the geofence. MAVLink autopilots get them too.
    rally_points: list[RallyPoint] = Field(default_factory=list, max_length=MAX_RALLY_POINTS)


class RecordOptions(MissionOptions):
    """The options as a mission record keeps them: the request's, and whether its steps were
    given by hand (then a later start flies them as given) or generated from its area."""

    model_config = ConfigDict(extra="ignore")  # records written by older versions load

    custom_steps: bool = True

    def request(self) -> MissionOptions:
        """The options as a request gives them (to plan the mission again at start)."""
        return MissionOptions.model_validate(self.model_dump(exclude={"custom_steps"}))


class LegRole(StrEnum):
    """Why a leg flies (seed 3.1.5 and 5.3's roles, and ours)."""

    PRIMARY = "primary"  # a share of the mission as planned (or of a grown area, for its finder)
    REPLACEMENT = "replacement"  # the rest of a replaced drone's share
    COLLABORATOR = "collaborator"  # a share of a grown area, for a drone that joined
    RECOVERY = "recovery"  # a replaced drone coming down where it is
    LEAVING = "leaving"  # a drone handed over early, flying what it keeps, then landing

    @property
    def outgoing(self) -> bool:
        """A leg that takes a drone out of the mission (never replaced again)."""
        return self in (LegRole.RECOVERY, LegRole.LEAVING)
