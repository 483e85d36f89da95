"""What the Drone Identifier knows about one drone (seed Fig. 4.21), and how liveness is judged.

A drone is ``online`` while heartbeats keep coming and ``lost`` once none has arrived for
:data:`LOST_AFTER_INTERVALS` heartbeat intervals. The interval is measured in wall time from the
heartbeats' arrival (a drone simulated 10x faster than real time sends its 5 s heartbeat every
0.5 s of wall time); until two have arrived, the heartbeat's own ``interval_s`` is used.
"""

from __future__ import annotations

from enum import StrEnum
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from dronefleet.clock import timestamp_s
from dronefleet.messaging.status import Heartbeat

LOST_AFTER_INTERVALS = 3
#: Wall seconds without a heartbeat before any drone is judged lost, however fast it beats.
MIN_LOST_AFTER_S = 2.0
#: Weight of the newest observed interval in the running estimate.
_SMOOTHING = 0.3


class DroneStatus(StrEnum):
    ONLINE = "online"
    LOST = "lost"  # no heartbeat for 3 intervals
    # Heartbeats arrive, but the drone cannot reach its autopilot: not flyable, not lost either.
    AUTOPILOT_LINK_LOST = "autopilot link lost"


class LenientHeartbeat(Heartbeat):
    """A heartbeat read on the ground: fields a newer drone adds are ignored, not refused."""

    model_config = ConfigDict(extra="ignore")


class DroneRecord(BaseModel):
    """One entry of the fleet: the last heartbeat, the gear, and when the drone was last heard."""

    drone_id: str
    status: DroneStatus = DroneStatus.ONLINE
    first_seen: float = Field(description="wall time (unix s) of the first heartbeat")
    last_seen: float = Field(description="wall time (unix s) of the last heartbeat")
    heartbeat_interval_s: float = Field(description="observed wall seconds between heartbeats")
    heartbeat: dict[str, Any] = Field(description="the last heartbeat as the drone sent it")
    specs: dict[str, Any] | None = None
    sensors: dict[str, Any] | None = None
    gear_updated: float | None = None
    status_changed: float | None = None

    model_config = ConfigDict(extra="ignore")

    @classmethod
    def first(cls, hb: Heartbeat, now: float) -> DroneRecord:
        return cls(
            drone_id=hb.drone_id,
            first_seen=now,
            last_seen=now,
            heartbeat_interval_s=max(hb.interval_s, 0.01),
            heartbeat=hb.model_dump(mode="json", exclude_none=True),
            status=DroneStatus.ONLINE if hb.autopilot_link else DroneStatus.AUTOPILOT_LINK_LOST,
            status_changed=now,
        )

    def observe(self, hb: Heartbeat, now: float) -> bool:
        """Take a new heartbeat; return True if the drone came back from ``lost``."""
        gap = now - self.last_seen
        came_back = self.status is DroneStatus.LOST
        # A gap across an outage says nothing about the drone's rate: only steady gaps count.
        if not came_back and 0 < gap < LOST_AFTER_INTERVALS * self.heartbeat_interval_s:
            if self.last_seen == self.first_seen:  # the second heartbeat: the first real gap
                self.heartbeat_interval_s = gap
            else:
                self.heartbeat_interval_s += _SMOOTHING * (gap - self.heartbeat_interval_s)
        self.last_seen = now
        self.heartbeat = hb.model_dump(mode="json", exclude_none=True)
        status = DroneStatus.ONLINE if hb.autopilot_link else DroneStatus.AUTOPILOT_LINK_LOST
        if status is not self.status:
            self.status = status
            self.status_changed = now
        return came_back

    def deadline(self, min_lost_after_s: float = MIN_LOST_AFTER_S) -> float:
        """Wall time after which, without a heartbeat, the drone is lost.

        Never sooner than ``min_lost_after_s`` (``dronefleet ground --lost-after``): a drone
        simulated many times faster than real time beats every fraction of a second, a busy host
        delays messages by more than that, and a link known to be lossy may want longer.
        """
        return self.last_seen + max(
            LOST_AFTER_INTERVALS * self.heartbeat_interval_s, min_lost_after_s
        )

    def seen_ago_s(self, now: float | None = None) -> float:
        return (timestamp_s() if now is None else now) - self.last_seen

    def public(self) -> dict[str, Any]:
        """The JSON shape every API answer uses (seed Fig. 4.21, plus liveness)."""
        hb = self.heartbeat
        return {
            "drone_id": self.drone_id,
            "status": self.status.value,
            "last_seen": self.last_seen,
            "seen_ago_s": round(self.seen_ago_s(), 3),
            "first_seen": self.first_seen,
            "heartbeat_interval_s": round(self.heartbeat_interval_s, 4),
            "position": hb.get("position"),
            "home": hb.get("home"),
            "battery": hb.get("battery"),
            "state": hb.get("state"),
            "mode": hb.get("mode"),
            "mission_id": hb.get("mission_id"),
            "step_index": hb.get("step_index"),
            "flight": hb.get("flight"),
            "ground_speed_mps": hb.get("ground_speed_mps"),
            "gps": hb.get("gps"),
            "wind": hb.get("wind"),
            "vehicle_time_s": hb.get("vehicle_time_s"),
            "specs": self.specs,
            "sensors": self.sensors,
        }
