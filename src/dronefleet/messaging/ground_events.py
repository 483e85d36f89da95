"""What ground services announce to each other and to the live stream (``ground/.../events``).

The Drone Identifier announces fleet changes (a new drone, one back online, one lost); the Mission
Planner announces mission changes (state, a leg sent, a handover, an extension). The live stream
(ground/manager/stream.py) validates both with these models before relaying them.
"""

from __future__ import annotations

from enum import StrEnum
from typing import Any

from pydantic import ConfigDict, Field

from dronefleet.messaging.common import DroneId, Message


class FleetChange(StrEnum):
    NEW = "new"
    ONLINE = "online"
    LOST = "lost"
    AUTOPILOT_LINK_LOST = "autopilot_link_lost"  # the drone is heard; its autopilot is not


class FleetEvent(Message):
    """On ``ground/identifier/events``."""

    event: FleetChange
    drone_id: DroneId
    drone: dict[str, Any] = Field(description="the drone as GET /api/v1/drones/{id} shows it")


class PlannerChange(StrEnum):
    MISSION = "mission"  # created, or its state changed (the record's summary follows)
    LEG = "leg"  # a leg sent to a drone
    HANDOVER = "handover"  # a drone's work handed to another (the handover follows)
    EXPANSION = "expansion"  # the area grown after an OUT_MEASURE alarm (the expansion follows)


class PlannerEvent(Message):
    """On ``ground/planner/events``: the event, its mission, and what describes the change."""

    model_config = ConfigDict(extra="allow")

    event: PlannerChange
    mission_id: str = Field(min_length=1, max_length=128)
