"""The live separation monitor (issue 14): drones closer than they should be, as it happens.

A ground service beside the Drone Identifier (seed Fig. 3.7). The plans are checked before they
are flown (ground/planner/deconflict/); this watches what is actually flown, whoever flies it —
a plan, an operator's direct commands, another ground station. From every drone's telemetry
(position and velocity, several times a second) and heartbeats (position, flight state), as the
ground's Fleet Inbox hands them (ground/inbox.py: read once for every ground service, on a queue
of the monitor's own), it keeps each drone's latest state and, whenever one moves, compares it
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

Each message of a drone in the air is compared only with the drones in the air near it, found
in a grid of 150-metre cubes on the Earth-centred frame (the 27 cubes around it,
ground/neighbour_grid.py), and a drone on the ground only with those it has an encounter with
(to end it): the cost per message does not grow with the fleet (issue 27; before, every message
was compared with every track, O(N) per message and the ground's largest cost at 100 drones).
Two drones more than a cube apart cannot breach within the horizon unless they close faster
than 50 m/s; an encounter whose pair has drifted apart is cleared as before. The tracks and the
arithmetic of a pair (a local flat-earth approximation, within centimetres of WGS84 at the few
hundred metres where it matters) are ground/separation_tracks.py's.
"""

from __future__ import annotations

import asyncio
import logging
import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

from pydantic import BaseModel, Field

from dronefleet.clock import monotonic, timestamp_s
from dronefleet.ground.courses import breach_along
from dronefleet.ground.inbox import FleetInbox
from dronefleet.ground.neighbour_grid import NeighbourGrid
from dronefleet.ground.planner.separation import HORIZONTAL_M, VERTICAL_M, WARNING_HORIZON_S
from dronefleet.ground.separation_tracks import (
    Track,
    age,
    cube,
    offset,
    origin,
    out_of_reach,
    track_of,
)
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.commands import AlarmLevel
from dronefleet.messaging.common import Position
from dronefleet.messaging.status import Alarm, FlightState, Heartbeat, Telemetry
from dronefleet.messaging.topics import SEPARATION_ALARMS

log = logging.getLogger(__name__)

#: Vehicle seconds ahead a breach on current velocities raises a WARNING ("a few seconds": a
#: multirotor at 10 m/s stops in 4 s; further ahead, drones stopping at their waypoints would
#: be foreseen running into each other).
HORIZON_S = WARNING_HORIZON_S
#: An encounter ends after this long clear (no new alarm for a pair flapping at the edge).
CLEAR_S = 3.0
#: A drone not heard for this long is not compared (its last position says little).
STALE_S = 5.0
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


@dataclass(slots=True)
class _Counts:
    """The counts of :class:`SeparationStatus`, kept as plain attributes."""

    predicted_breaches: int = 0
    actual_breaches: int = 0
    min_distance_m: float | None = None
    min_horizontal_m: float | None = None
    pairs_compared: int = 0

    def measure(self, flat: float, up: float) -> None:
        """A pair compared, ``flat`` metres apart over the ground and ``up`` vertically."""
        self.pairs_compared += 1
        distance = math.hypot(flat, up)
        if self.min_distance_m is None or distance < self.min_distance_m:
            self.min_distance_m = round(distance, 2)
        if abs(up) < VERTICAL_M and (self.min_horizontal_m is None or flat < self.min_horizontal_m):
            self.min_horizontal_m = round(flat, 2)


@dataclass
class _Encounter:
    level: AlarmLevel
    clear_since: float | None = None


class SeparationMonitor:
    """``await SeparationMonitor(url, client_id=...).start()``; ``status()`` for the counts."""

    def __init__(
        self,
        broker_url: Any,
        *,
        client_id: str,
        horizon_s: float = HORIZON_S,
        inbox: FleetInbox | None = None,
    ) -> None:
        self.client = BrokerClient(broker_url, client_id)  # its alarms go out on it
        #: Telemetry and heartbeats; alone (no ground's inbox given), an inbox of its own.
        self.inbox = inbox or FleetInbox(broker_url, client_id=f"{client_id}-inbox")
        self._own_inbox = inbox is None
        self.horizon_s = horizon_s
        #: The clocks messages are timed by: the running loop's once started (see start).
        self._now: Callable[[], float] = monotonic
        self._wall: Callable[[], float] = timestamp_s
        self.tracks: dict[str, Track] = {}
        self.encounters: dict[tuple[str, str], _Encounter] = {}
        #: The counts, a plain object (a pydantic model's attribute writes cost per pair).
        self.counts = _Counts()
        self.dropped = 0  # raw messages (:meth:`_on_telemetry`) that did not validate
        #: Called with each alarm raised, as sent (the alarm log: ground/alarm_log.py).
        self.alarm_listeners: list[Callable[[dict[str, Any]], None]] = []
        self.grid = NeighbourGrid()  # the drones in the air, by cube (ground/neighbour_grid.py)
        self._partners: dict[str, set[str]] = {}  # drone -> drones it has an encounter with

    async def start(self) -> SeparationMonitor:
        # The running loop's clocks, taken once: clock.monotonic() asks for the running loop at
        # each call, and Python 3.11's get_running_loop() makes a getpid() system call each time
        # (a fork check), three a message here (issue 27).
        loop = asyncio.get_running_loop()
        self._now = loop.time
        self._wall = getattr(loop, "epoch_time", None) or time.time
        # Partitioned (ground/partition.py), a replica compares its own drones' messages; the
        # other replicas' drones are its neighbours, placed from their owners' pictures.
        self.inbox.telemetry.queued("separation monitor", self.on_telemetry, takes="own")
        self.inbox.telemetry.direct("separation neighbours", self.place_peer, takes="peers")
        self.inbox.heartbeats.queued("separation monitor", self.on_heartbeat)
        await self.client.start()
        if self._own_inbox:
            await self.inbox.start()
        return self

    async def stop(self) -> None:
        for feed in (self.inbox.telemetry, self.inbox.heartbeats):
            await feed.detach("separation monitor")
        await self.inbox.telemetry.detach("separation neighbours")
        if self._own_inbox:
            await self.inbox.stop()
        await self.client.stop()

    def status(self) -> SeparationStatus:
        active = sorted(f"{a}/{b}" for a, b in self.encounters)
        return SeparationStatus(horizon_s=self.horizon_s, active=active, **asdict(self.counts))

    # -- input ---------------------------------------------------------------------------------
    async def _on_telemetry(self, topic_name: str, payload: bytes) -> None:
        """A message as the broker delivers it, read as the inbox reads it (tests feed these)."""
        msg = self.inbox.read(self.inbox.telemetry, topic_name, payload)
        if msg is None:
            self.dropped += 1
            return
        await self.on_telemetry(msg)

    async def on_telemetry(self, msg: Telemetry) -> None:
        """A drone's telemetry as the inbox read it: its track moved, compared with its
        neighbours."""
        now = self._now()
        track = track_of(msg, now)
        if track is not None:
            self._place(msg.drone_id, track)
            await self._compare(msg.drone_id, now)

    def place_peer(self, msg: Telemetry) -> None:
        """Another replica's drone, from its picture: placed as a neighbour, compared by its
        owner (its age counted from its timestamp, at most :data:`MAX_EXTRAPOLATION_S`)."""
        now = self._now()
        track = track_of(msg, now - min(max(self._wall() - msg.timestamp, 0.0), STALE_S))
        if track is not None:
            self._place(msg.drone_id, track)

    async def on_heartbeat(self, hb: Heartbeat) -> None:
        """A drone's heartbeat as the inbox read it: its track, when its telemetry is stale."""
        now = self._now()
        known = self.tracks.get(hb.drone_id)
        if known is not None and now - known.telemetry_s < STALE_S:
            return  # its telemetry says more (velocity too), and more often
        p = hb.position
        track = Track(p.lat, p.lon, p.alt_m, in_air=hb.state in _AIRBORNE, seen_s=now)
        track.vehicle_time_s = hb.vehicle_time_s
        self._place(hb.drone_id, track)
        await self._compare(hb.drone_id, now)

    # -- comparison ----------------------------------------------------------------------------
    def _foreseen(
        self, a: Track, b: Track, rel: tuple[float, float, float], now: float
    ) -> float | None:
        """When, on their courses (ground/courses.py), ``a`` and ``b`` would be within the
        minima; None: not within the horizon."""
        a_course, b_course = a.course.later(age(a, now)), b.course.later(age(b, now))
        return breach_along(rel, a_course, b_course, self.horizon_s)

    def _place(self, drone_id: str, track: Track) -> None:
        """Keep ``track`` as the drone's latest and, while it is in the air, in the cube of the
        grid it is in: only drones in the air are compared, so a crowd on the ground (a fleet
        waiting at its homes, 36 drones a cube in bench/sim_scale.py's 1000) costs a message
        nothing (issue 27)."""
        self.tracks[drone_id] = track
        self.grid.place(drone_id, cube(track) if track.in_air else None)

    def _near(self, drone_id: str) -> set[str]:
        """The drones in the air in the 27 cubes around ``drone_id``'s when it is in the air,
        and those it has an encounter with (so that one ends even when they have drifted apart
        or landed)."""
        return set(self._around(drone_id)) - {drone_id}

    def _around(self, drone_id: str) -> tuple[str, ...]:
        """:meth:`_near`, sorted (alarms come in the same order whatever the sets' order), and
        ``drone_id`` itself when in the air: the grid's kept tuple when the drone has no
        encounter, the usual case, so a message builds nothing."""
        around = self.grid.around(drone_id)
        partners = self._partners.get(drone_id)
        if partners:
            around = tuple(sorted(set(around) | partners))
        return around

    async def _compare(self, drone_id: str, now: float) -> None:
        """``drone_id``'s track against each neighbour's."""
        tracks, counts, horizon = self.tracks, self.counts, self.horizon_s
        me = tracks[drone_id]
        here = origin(me, now)  # once for all its neighbours
        for other_id in self._around(drone_id):
            if other_id == drone_id:
                continue
            other = tracks[other_id]
            pair = (drone_id, other_id) if drone_id < other_id else (other_id, drone_id)
            if not (me.in_air and other.in_air) or now - other.seen_s > STALE_S:
                if pair in self.encounters:
                    await self._clear(pair, now)
                continue
            rel = offset(here, other, now)
            flat, u = math.hypot(rel[0], rel[1]), rel[2]
            counts.measure(flat, u)
            if flat < HORIZONTAL_M and abs(u) < VERTICAL_M:
                await self._raise(pair, AlarmLevel.CRITICAL, me, other, rel, 0.0)
                continue
            ahead = None
            if not out_of_reach(me, other, flat, u, horizon):
                ahead = self._foreseen(me, other, rel, now)
            if ahead is not None:
                await self._raise(pair, AlarmLevel.WARNING, me, other, rel, ahead)
            elif pair in self.encounters:
                await self._clear(pair, now)

    async def _clear(self, pair: tuple[str, str], now: float) -> None:
        encounter = self.encounters.get(pair)
        if encounter is None:
            return
        if encounter.clear_since is None:
            encounter.clear_since = now
        elif now - encounter.clear_since >= CLEAR_S:
            del self.encounters[pair]
            for a, b in (pair, pair[::-1]):
                partners = self._partners.get(a)
                if partners is not None:
                    partners.discard(b)
                    if not partners:
                        del self._partners[a]
            log.info("separation: %s and %s clear again", *pair)

    async def _raise(
        self,
        pair: tuple[str, str],
        level: AlarmLevel,
        me: Track,
        other: Track,
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
            self._partners.setdefault(pair[0], set()).add(pair[1])
            self._partners.setdefault(pair[1], set()).add(pair[0])
        if level is AlarmLevel.CRITICAL:
            self.counts.actual_breaches += 1
        else:
            self.counts.predicted_breaches += 1
        await self._publish(pair, level, me, other, rel, ahead_s)

    async def _publish(
        self,
        pair: tuple[str, str],
        level: AlarmLevel,
        me: Track,
        other: Track,
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
        for listener in self.alarm_listeners:
            listener(alarm.model_dump(mode="json", exclude_none=True))
        try:
            await self.client.publish(SEPARATION_ALARMS, alarm, qos=1)
        except Exception as exc:  # the counts stand; the stream misses this one
            log.warning("separation alarm not published: %s", exc)
