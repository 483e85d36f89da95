"""The Mission Planner's view of the fleet: asked of the Drone Identifier over the ground broker
(seed Fig. 4.31-4.32), and the selection rules for replacement and collaboration (seed 4.2.4:
available drones, nearest first, with enough battery).
"""

from __future__ import annotations

import secrets
from dataclasses import dataclass
from typing import Any

from dronefleet.geo.distance import distance_m
from dronefleet.geo.types import LLA
from dronefleet.ground.identifier import QUERY_TOPIC, identifier_query
from dronefleet.messaging.rpc import Requester
from dronefleet.messaging.topics import ground

IDLE_STATES = frozenset({"disarmed", "armed", "flying"})


@dataclass(frozen=True)
class DroneView:
    """What selection needs to know about one drone."""

    drone_id: str
    online: bool
    state: str
    mission_id: str | None
    position: LLA
    home: LLA
    battery_pct: float
    flight: dict[str, Any] | None = None  # how its vehicle flies (Heartbeat.flight)
    wind: dict[str, Any] | None = None  # its autopilot's wind estimate (Heartbeat.wind)
    seen_ago_s: float | None = None  # since the Drone Identifier last heard it
    ground_speed_mps: float | None = None  # in its last heartbeat

    @property
    def airborne(self) -> bool:
        return self.state in {"flying", "taking_off", "landing"}

    @property
    def idle(self) -> bool:
        return self.online and self.mission_id is None and self.state in IDLE_STATES

    @classmethod
    def from_public(cls, d: dict[str, Any]) -> DroneView | None:
        pos, home, battery = d.get("position"), d.get("home") or d.get("position"), d.get("battery")
        if not pos or not home or not battery:
            return None
        return cls(
            drone_id=d["drone_id"],
            online=d.get("status") == "online",
            state=str(d.get("state")),
            mission_id=d.get("mission_id"),
            position=LLA(pos["lat"], pos["lon"], pos.get("alt_m", 0.0)),
            home=LLA(home["lat"], home["lon"], home.get("alt_m", 0.0)),
            battery_pct=float(battery.get("remaining_pct", 0.0)),
            flight=d.get("flight") if isinstance(d.get("flight"), dict) else None,
            wind=d.get("wind") if isinstance(d.get("wind"), dict) else None,
            seen_ago_s=_number(d.get("seen_ago_s")),
            ground_speed_mps=_number(d.get("ground_speed_mps")),
        )


def _number(value: Any) -> float | None:
    return float(value) if isinstance(value, int | float) else None


class FleetView:
    def __init__(self, requester: Requester, *, timeout_s: float = 3.0) -> None:
        self.requester = requester
        self.timeout_s = timeout_s
        self.reply_topic = ground("planner", secrets.token_hex(4), "identifier")

    async def records(self) -> list[dict[str, Any]]:
        """Every drone as the Drone Identifier publishes it (liveness, gear, GPS, wind...)."""
        message = {**identifier_query("discover"), "reply_to": self.reply_topic}
        answer = await self.requester.request(
            QUERY_TOPIC, self.reply_topic, message, timeout_s=self.timeout_s
        )
        return [d for d in answer.get("drones") or [] if isinstance(d, dict)]

    async def drones(self) -> list[DroneView]:
        views = (DroneView.from_public(d) for d in await self.records())
        return [v for v in views if v is not None]

    async def drone(self, drone_id: str) -> DroneView | None:
        return next((d for d in await self.drones() if d.drone_id == drone_id), None)


def candidates(
    drones: list[DroneView], near: LLA, *, exclude: set[str], min_battery_pct: float = 0.0
) -> list[DroneView]:
    """Idle, online drones not excluded, with the battery asked for, nearest to ``near`` first."""
    chosen = [
        d
        for d in drones
        if d.idle and d.drone_id not in exclude and d.battery_pct >= min_battery_pct
    ]
    return sorted(chosen, key=lambda d: (distance_m(d.position, near), -d.battery_pct))
