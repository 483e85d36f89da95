"""What the Mission Planner hears from drones (reports, alarms), read once: a message that is not
valid, or that claims another drone than its topic's, is counted under its kind (health shows
``dropped``) and dropped, with one log line per kind per 10 s so that junk on the broker cannot
flood the log."""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, TypeVar

from dronefleet.messaging.codec import MessageError
from dronefleet.messaging.inbound import parse_message, speaks_for_itself
from dronefleet.messaging.log_throttle import LogThrottle
from dronefleet.messaging.missions import MissionProgress
from dronefleet.messaging.status import Alarm

if TYPE_CHECKING:
    from dronefleet.ground.planner.service import MissionPlanner

log = logging.getLogger(__name__)
_throttle = LogThrottle(log)

M = TypeVar("M", Alarm, MissionProgress)


def read(
    planner: MissionPlanner, kind: str, model: type[M], topic_name: str, payload: bytes
) -> M | None:
    """``payload`` as ``model``, sent by the drone its topic names; else None, counted, logged."""
    try:
        message = parse_message(model, payload)
        speaks_for_itself(topic_name, message.drone_id)
    except MessageError as exc:
        planner.dropped[kind] += 1
        _throttle.log(logging.WARNING, kind, "dropping %s on %s: %s", kind, topic_name, exc)
        return None
    return message
