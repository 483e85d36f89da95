"""The live separation monitor (issue 14): drones closer than they should be, as it happens.

A ground service beside the Drone Identifier (seed Fig. 3.7), with its own broker connection. The
plans are checked before they are flown (ground/planner/deconflict.py); this watches what is
actually flown, whoever flies it — a plan, an operator's direct commands, another ground station.
From every drone's telemetry (position and velocity, several times a second) and heartbeats
(position, flight state) it keeps each drone's latest state and, whenever one moves, compares it
with every other drone in the air:

- **CRITICAL**: closer than 5 m horizontally and 3 m vertically now (ground/planner/separation.py:
  the same minima as the plans);
- **WARNING**: on their courses they will be within :data:`HORIZON_S` seconds: each at its
  speed towards the goal its telemetry names, stopping there, or on at its velocity without one
  (ground/courses.py).

An alarm is raised once per encounter (a pair's encounter ends after :data:`CLEAR_S` seconds
clear), as the shared :class:`~dronefleet.messaging.status.Alarm` on
``ground/separation/alarms``, which the live stream relays as an ``alarm`` (the web apps' alarm
toasts). It is not sent on a drone's own alarm topic: the planner answers a drone's CRITICAL with
a replacement, which is not what two drones too close need. Encounters are counted (predicted and
actual) with the smallest separations seen, served at ``GET /api/v1/separation`` and printed by
the experiments.

Positions are compared in a local flat-earth approximation (metres per degree at the pair's
latitude): at the few hundred metres where it matters it is within centimetres of the WGS84
frame and costs no allocation per pair, so a fleet's telemetry never loads the event loop.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import Any

from pydantic import BaseModel, Field

from dronefleet.clock import monotonic
from dronefleet.ground.courses import Course, breach_along, course_to
from dronefleet.ground.planner.separation import HORIZONTAL_M, VERTICAL_M, WARNING_HORIZON_S
from dronefleet.messaging.client import QOS_STREAM, BrokerClient
from dronefleet.messaging.codec import MessageError
from dronefleet.messaging.commands import AlarmLevel
from dronefleet.messaging.common import Position
from dronefleet.messaging.inbound import parse_message, speaks_for_itself
from dronefleet.messaging.status import Alarm, FlightState, Heartbeat, Telemetry
from dronefleet.messaging.topics import SEPARATION_ALARMS, Channel, any_drone

log = logging.getLogger(__name__)

#: Vehicle seconds ahead a breach on current velocities raises a WARNING ("a few seconds": a
#: multirotor at 10 m/s stops in 4 s; further ahead, drones stopping at their waypoints would
#: be foreseen running into each other).
HORIZON_S = WARNING_HORIZON_S
#: An encounter ends after this long clear (no new alarm for a pair flapping at the edge).
CLEAR_S = 3.0
#: A drone not heard for this long is not compared (its last position says little).
STALE_S = 5.0
#: Positions are moved on by their velocity at most this long (old telemetry is not a forecast).
MAX_EXTRAPOLATION_S = 1.0
_M_PER_DEG = 111_320.0
_AIRBORNE = frozenset({FlightState.TAKING_OFF, FlightState.FLYING, FlightState.LANDING})


class SeparationStatus(BaseModel):
    """What the monitor has seen since the ground started (``GET /api/v1/separation``)."""

    horizontal_m: float = Field(default=HORIZONTAL_M, description="the horizontal minimum")
    vertical_m: float = Field(default=VERTICAL_M, description="the vertical minimum")
    horizon_s: float = Field(default=HORIZON_S, description="how far ahead a breach is predicted")
    predicted_breaches: int = Field(default=0, description="encounters that raised a WARNING")
    actual_breaches: int = Field(default=0, description="encounters that raised a CRITICAL")
    min_distance_m: float | None = Field(
        default=None, description="the smallest 3-D distance between two drones in the air"
    )
    min_horizontal_m: float | None = Field(
        default=None,
        description="the smallest horizontal distance between two drones in the air while "
        "within the vertical minimum of each other",
    )
    pairs_compared: int = Field(default=0, description="pair comparisons made")
    active: list[str] = Field(default_factory=list, description="pairs in an encounter now")


@dataclass
class _Track:
    lat: float
    lon: float
    alt_m: float
    vn: float = 0.0
    ve: float = 0.0
    vd: float = 0.0
    in_air: bool = False
    seen_s: float = 0.0  # monotonic() when heard
    vehicle_time_s: float = 0.0
    telemetry_s: float = -math.inf  # monotonic() of its last telemetry
    course: Course = field(default_factory=lambda: Course((0.0, 0.0, 0.0)))  # what it flies next


def _course(f: dict[str, float]) -> Course:
    """What a drone whose telemetry fields are ``f`` is expected to fly next: on to the goal
    they name, if any (ground/courses.py). Worked out once per message, not once per pair."""
    vel = (f.get("vn", 0.0), f.get("ve", 0.0), -f.get("vd", 0.0))
    if not {"goal_lat", "goal_lon", "goal_alt_m"} <= f.keys():
        return course_to(vel, None)
    east_m_per_deg = _M_PER_DEG * math.cos(math.radians(f["lat"]))
    to_goal = ((f["goal_lat"] - f["lat"]) * _M_PER_DEG, (f["goal_lon"] - f["lon"]) * east_m_per_deg,
               f["goal_alt_m"] - f["alt_m"])  # fmt: skip
    return course_to(vel, to_goal)


@dataclass
class _Encounter:
    level: AlarmLevel
    clear_since: float | None = None


class SeparationMonitor:
    """``await SeparationMonitor(url, client_id=...).start()``; ``status()`` for the counts."""

    def __init__(self, broker_url: Any, *, client_id: str, horizon_s: float = HORIZON_S) -> None:
        self.client = BrokerClient(broker_url, client_id)
        self.horizon_s = horizon_s
        self.tracks: dict[str, _Track] = {}
        self.encounters: dict[tuple[str, str], _Encounter] = {}
        self.counts = SeparationStatus(horizon_s=horizon_s)
        self.dropped = 0  # messages that did not validate

    async def start(self) -> SeparationMonitor:
        await self.client.subscribe(
            any_drone(Channel.TELEMETRY), self._on_telemetry, qos=QOS_STREAM
        )
        await self.client.subscribe(
            any_drone(Channel.HEARTBEATS), self._on_heartbeat, qos=QOS_STREAM
        )
        await self.client.start()
        return self

    async def stop(self) -> None:
        await self.client.stop()

    def status(self) -> SeparationStatus:
        active = sorted(f"{a}/{b}" for a, b in self.encounters)
        return self.counts.model_copy(update={"active": active})

    # -- input ---------------------------------------------------------------------------------
    async def _on_telemetry(self, topic_name: str, payload: bytes) -> None:
        try:
            msg = parse_message(Telemetry, payload)
            speaks_for_itself(topic_name, msg.drone_id)
        except (MessageError, ValueError):
            self.dropped += 1
            return
        f = msg.fields
        if not {"lat", "lon", "alt_m"} <= f.keys():
            return
        now = monotonic()
        track = _Track(f["lat"], f["lon"], f["alt_m"], f.get("vn", 0.0), f.get("ve", 0.0))
        track.vd, track.in_air = f.get("vd", 0.0), bool(f.get("in_air", 0.0))
        track.course = _course(f)
        track.seen_s = track.telemetry_s = now
        track.vehicle_time_s = msg.vehicle_time_s
        self.tracks[msg.drone_id] = track
        await self._compare(msg.drone_id, now)

    async def _on_heartbeat(self, topic_name: str, payload: bytes) -> None:
        try:
            hb = parse_message(Heartbeat, payload)
            speaks_for_itself(topic_name, hb.drone_id)
        except (MessageError, ValueError):
            self.dropped += 1
            return
        now = monotonic()
        known = self.tracks.get(hb.drone_id)
        if known is not None and now - known.telemetry_s < STALE_S:
            return  # its telemetry says more (velocity too), and more often
        p = hb.position
        track = _Track(p.lat, p.lon, p.alt_m, in_air=hb.state in _AIRBORNE, seen_s=now)
        track.vehicle_time_s = hb.vehicle_time_s
        self.tracks[hb.drone_id] = track
        await self._compare(hb.drone_id, now)

    # -- comparison ----------------------------------------------------------------------------
    def _relative(self, a: _Track, b: _Track, now: float) -> tuple[float, float, float]:
        """Where ``b`` is from ``a`` (n, e, up metres), now."""
        east_m_per_deg = _M_PER_DEG * math.cos(math.radians(a.lat))
        da, db = _age(a, now), _age(b, now)
        n = (b.lat - a.lat) * _M_PER_DEG + b.vn * db - a.vn * da
        e = (b.lon - a.lon) * east_m_per_deg + b.ve * db - a.ve * da
        u = (b.alt_m - b.vd * db) - (a.alt_m - a.vd * da)
        return n, e, u

    def _foreseen(
        self, a: _Track, b: _Track, rel: tuple[float, float, float], now: float
    ) -> float | None:
        """When, on their courses (ground/courses.py), ``a`` and ``b`` would be within the
        minima; None: not within the horizon."""
        a_course, b_course = a.course.later(_age(a, now)), b.course.later(_age(b, now))
        return breach_along(rel, a_course, b_course, self.horizon_s)

    async def _compare(self, drone_id: str, now: float) -> None:
        me = self.tracks[drone_id]
        for other_id, other in list(self.tracks.items()):
            if other_id == drone_id:
                continue
            pair = (drone_id, other_id) if drone_id < other_id else (other_id, drone_id)
            if not (me.in_air and other.in_air) or now - other.seen_s > STALE_S:
                await self._clear(pair, now)
                continue
            rel = self._relative(me, other, now)
            self._measure(rel)
            flat = math.hypot(rel[0], rel[1])
            if flat < HORIZONTAL_M and abs(rel[2]) < VERTICAL_M:
                await self._raise(pair, AlarmLevel.CRITICAL, me, other, rel, 0.0)
                continue
            ahead = self._foreseen(me, other, rel, now)
            if ahead is not None:
                await self._raise(pair, AlarmLevel.WARNING, me, other, rel, ahead)
            else:
                await self._clear(pair, now)

    def _measure(self, rel: tuple[float, float, float]) -> None:
        c = self.counts
        c.pairs_compared += 1
        flat = math.hypot(rel[0], rel[1])
        distance = math.hypot(flat, rel[2])
        if c.min_distance_m is None or distance < c.min_distance_m:
            c.min_distance_m = round(distance, 2)
        if abs(rel[2]) < VERTICAL_M and (c.min_horizontal_m is None or flat < c.min_horizontal_m):
            c.min_horizontal_m = round(flat, 2)

    async def _clear(self, pair: tuple[str, str], now: float) -> None:
        encounter = self.encounters.get(pair)
        if encounter is None:
            return
        if encounter.clear_since is None:
            encounter.clear_since = now
        elif now - encounter.clear_since >= CLEAR_S:
            del self.encounters[pair]
            log.info("separation: %s and %s clear again", *pair)

    async def _raise(
        self,
        pair: tuple[str, str],
        level: AlarmLevel,
        me: _Track,
        other: _Track,
        rel: tuple[float, float, float],
        ahead_s: float,
    ) -> None:
        encounter = self.encounters.get(pair)
        if encounter is not None:
            encounter.clear_since = None
            if encounter.level is AlarmLevel.CRITICAL or level is encounter.level:
                return  # already raised at this level (or worse) in this encounter
            encounter.level = level
        else:
            self.encounters[pair] = _Encounter(level)
        if level is AlarmLevel.CRITICAL:
            self.counts.actual_breaches += 1
        else:
            self.counts.predicted_breaches += 1
        await self._publish(pair, level, me, other, rel, ahead_s)

    async def _publish(
        self,
        pair: tuple[str, str],
        level: AlarmLevel,
        me: _Track,
        other: _Track,
        rel: tuple[float, float, float],
        ahead_s: float,
    ) -> None:
        flat, vertical = math.hypot(rel[0], rel[1]), abs(rel[2])
        when = "now" if level is AlarmLevel.CRITICAL else f"in {ahead_s:.1f} s on their course"
        message = (
            f"separation: {pair[0]} and {pair[1]} {flat:.1f} m apart horizontally and"
            f" {vertical:.1f} m vertically; within {HORIZONTAL_M:g} m / {VERTICAL_M:g} m {when}"
        )
        log.warning(message)
        alarm = Alarm(
            drone_id=pair[0],
            level=level,
            message=message,
            position=Position(
                lat=(me.lat + other.lat) / 2,
                lon=(me.lon + other.lon) / 2,
                alt_m=(me.alt_m + other.alt_m) / 2,
            ),
            reading={
                "other_drone": pair[1],
                "horizontal_m": round(flat, 2),
                "vertical_m": round(vertical, 2),
                "in_s": round(ahead_s, 1),
            },
            vehicle_time_s=max(me.vehicle_time_s, other.vehicle_time_s),
        )
        try:
            await self.client.publish(SEPARATION_ALARMS, alarm, qos=1)
        except Exception as exc:  # the counts stand; the stream misses this one
            log.warning("separation alarm not published: %s", exc)


def _age(track: _Track, now: float) -> float:
    """How far its last position is moved on by its velocity (bounded: see MAX_EXTRAPOLATION_S)."""
    return min(max(now - track.seen_s, 0.0), MAX_EXTRAPOLATION_S)
