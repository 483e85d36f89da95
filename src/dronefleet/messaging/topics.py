"""The seed's topics (Table 4.4), built in one place.

``<drone_id>/{control,mission,gear}/{in,out}`` and ``<drone_id>/{heartbeats,alarms,telemetry}/out``.
Ground-internal topics live under ``ground/...``. Call sites never paste topic strings together.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from enum import StrEnum

from dronefleet.errors import InvalidInput


class Channel(StrEnum):
    CONTROL = "control"
    MISSION = "mission"
    GEAR = "gear"
    HEARTBEATS = "heartbeats"
    ALARMS = "alarms"
    TELEMETRY = "telemetry"


class Direction(StrEnum):
    IN = "in"  # towards the drone
    OUT = "out"  # from the drone


#: Channels that only flow out of the drone.
OUT_ONLY = frozenset({Channel.HEARTBEATS, Channel.ALARMS, Channel.TELEMETRY})

#: A drone id: 1-64 letters, digits, '_' or '-'; never an MQTT wildcard or separator, and valid
#: on every supported broker: no '.', which RabbitMQ's MQTT adapter turns into a topic level
#: separator (``QUAD.3/telemetry/out`` is routed as ``QUAD/3/telemetry/out``) and NATS refuses
#: in the client ids made from it.
DRONE_ID_RE = re.compile(r"^[A-Za-z0-9_\-]{1,64}$")

GROUND_PREFIX = "ground"


class TopicError(InvalidInput, ValueError):
    """A topic or drone id that does not fit the seed's scheme."""


def check_drone_id(drone_id: str) -> str:
    if (
        not isinstance(drone_id, str)
        or not DRONE_ID_RE.fullmatch(drone_id)  # fullmatch: no "ID\n"
        or drone_id == GROUND_PREFIX
    ):
        raise TopicError(
            f"invalid drone id {drone_id!r}: use 1-64 letters, digits, '_' or '-' (not 'ground')"
        )
    return drone_id


def topic(drone_id: str, channel: Channel, direction: Direction) -> str:
    """The topic of one drone's channel, e.g. ``topic("QUAD_1", Channel.CONTROL, Direction.IN)``."""
    if channel in OUT_ONLY and direction is Direction.IN:
        raise TopicError(f"channel {channel} only flows out of the drone")
    return f"{check_drone_id(drone_id)}/{channel}/{direction}"


def any_drone(channel: Channel, direction: Direction = Direction.OUT) -> str:
    """Subscription pattern for one channel of every drone, e.g. ``+/telemetry/out``."""
    return f"+/{channel}/{direction}"


def drone_all(drone_id: str) -> str:
    """Subscription pattern for every topic of one drone (what the Logger listens to)."""
    return f"{check_drone_id(drone_id)}/#"


def ground(*parts: str) -> str:
    """A ground-internal topic, e.g. ``ground("identifier", "in")``."""
    return "/".join((GROUND_PREFIX, *parts))


@dataclass(frozen=True)
class DroneTopic:
    drone_id: str
    channel: Channel
    direction: Direction


def parse(topic_name: str) -> DroneTopic:
    """Split a drone topic into its parts; raise :class:`TopicError` if it is not one."""
    parts = topic_name.split("/")
    if len(parts) != 3:
        raise TopicError(f"not a drone topic: {topic_name!r}")
    drone_id, channel, direction = parts
    try:
        return DroneTopic(check_drone_id(drone_id), Channel(channel), Direction(direction))
    except ValueError as exc:
        raise TopicError(f"not a drone topic: {topic_name!r}") from exc


#: What the Drone Identifier tells the other ground services (a drone new, lost, back online).
IDENTIFIER_EVENTS = ground("identifier", "events")

#: What the Mission Planner tells the web apps (mission created, leg started, handover...).
PLANNER_EVENTS = ground("planner", "events")
#: The ground's separation monitor raises its alarms here (shared Alarm model), not on a drone's
#: alarm topic: a separation alarm is the ground's, and must not look like a drone's CRITICAL.
SEPARATION_ALARMS = ground("separation", "alarms")
