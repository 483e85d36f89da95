"""What the Drone Identifier knows about one drone (seed Fig. 4.21), and how liveness is judged
(docs/DESIGN.md §4, issue 26).

A drone is ``online`` while heartbeats keep coming and ``lost`` once it has been silent for
:meth:`DroneRecord.lost_after_s`: :data:`LOST_AFTER_INTERVALS` of its heartbeat intervals, never
less than the ground's ``--lost-after`` floor. Silence is counted in the ground's *awake* time
(:class:`AwakeClock`), not in wall time: while the ground itself was stalled (its event loop
late), deaf (its broker link down, or its subscription not yet made) or restarting, no drone's
silence grows, so a ground never declares a drone lost for its own delay.

The interval is the drone's own: each heartbeat declares ``interval_s`` in vehicle seconds, and
the drone's clock rate (vehicle seconds per wall second: 10 for a simulation sped up 10 times)
is read from the heartbeats' own stamps, the vehicle time and the sender's wall time, as the
median over the last few pairs. Arrival times play no part, so heartbeats delivered in a burst
(a backlog, a bridge catching up) cannot shrink it; a wild pair is outvoted; the result is kept
within :data:`MIN_INTERVAL_S` .. :data:`MAX_INTERVAL_S`.
"""

from __future__ import annotations

import asyncio
import statistics
from collections import deque
from enum import StrEnum
from typing import Any, cast

from pydantic import BaseModel, ConfigDict, Field, PrivateAttr

from dronefleet.clock import monotonic, timestamp_s
from dronefleet.messaging.status import Heartbeat

LOST_AFTER_INTERVALS = 3
#: Wall seconds without a heartbeat before any drone is judged lost, however fast it beats.
MIN_LOST_AFTER_S = 2.0
#: The wall interval a drone's heartbeats are judged by is kept within these bounds.
MIN_INTERVAL_S = 0.05
MAX_INTERVAL_S = 3600.0
#: Heartbeat pairs whose stamps give the drone's clock rate (the median of them is used).
RATE_PAIRS = 9
#: Pairs closer than this in the sender's wall time say nothing reliable about a rate.
MIN_PAIR_S = 0.01
#: The ground's liveness tick, and how late a tick may come and still count as awake time whole.
TICK_S = 0.05
TICK_SLACK_S = 0.2


class DroneStatus(StrEnum):
    ONLINE = "online"
    LOST = "lost"  # silent for LOST_AFTER_INTERVALS intervals of the ground's awake time
    # Heartbeats arrive, but the drone cannot reach its autopilot: not flyable, not lost either.
    AUTOPILOT_LINK_LOST = "autopilot link lost"


class LenientHeartbeat(Heartbeat):
    """A heartbeat read on the ground: fields a newer drone adds are ignored, not refused."""

    model_config = ConfigDict(extra="ignore")


class AwakeClock:
    """The ground's own time awake: loop time less the time it was stalled or deaf.

    :meth:`tick` is called every :data:`TICK_S`; a tick that comes later than ``tick_s +
    slack_s`` means the event loop was held up (a blocking call, a host under load, a process
    stopped and resumed), and only ``tick_s + slack_s`` of the gap counts. Time while the ground
    does not listen (``listening=False``) does not count at all.
    """

    def __init__(
        self, now: float | None = None, *, tick_s: float = TICK_S, slack_s: float = TICK_SLACK_S
    ) -> None:
        self.tick_s = tick_s
        self.slack_s = slack_s
        self._last = monotonic() if now is None else now
        self.awake_s = 0.0  # awake seconds so far
        self.stalled_s = 0.0  # seconds the ground's loop was late, not counted
        self.deaf_s = 0.0  # seconds it did not listen, not counted
        self.last_stall_s = 0.0  # the lateness found by the last tick

    def _credit(self, elapsed: float) -> float:
        return min(max(0.0, elapsed), self.tick_s + self.slack_s)

    def tick(self, now: float | None = None, *, listening: bool = True) -> float:
        """Count the time since the last tick; return the awake time now."""
        now = monotonic() if now is None else now
        elapsed = max(0.0, now - self._last)
        self._last = now
        if not listening:
            self.deaf_s += elapsed
            self.last_stall_s = 0.0
            return self.awake_s
        credit = self._credit(elapsed)
        self.awake_s += credit
        self.last_stall_s = elapsed - credit
        self.stalled_s += self.last_stall_s
        return self.awake_s

    def now(self, now: float | None = None) -> float:
        """The awake time at ``now`` (between ticks: the last tick's, plus what may count since)."""
        now = monotonic() if now is None else now
        return self.awake_s + self._credit(now - self._last)


async def sleep_awake(duration_s: float, *, tick_s: float = 0.1) -> float:
    """Sleep until ``duration_s`` of the ground's awake time has passed (a stall of the event
    loop does not count: see :class:`AwakeClock`); return the loop seconds it took."""
    clock = AwakeClock(tick_s=tick_s)
    started = monotonic()
    while clock.awake_s < duration_s:
        await asyncio.sleep(min(tick_s, duration_s - clock.awake_s))
        clock.tick()
    return monotonic() - started


#: The telemetry fields that make a drone's position.
_POSITION_KEYS = ("lat", "lon", "alt_m", "relative_alt_m")


def _private(record: BaseModel) -> dict[str, Any]:
    """``record``'s private attributes, read directly (see DroneRecord's)."""
    return cast(dict[str, Any], record.__pydantic_private__)


class DroneRecord(BaseModel):
    """One entry of the fleet: the last heartbeat, the gear, and when the drone was last heard."""

    drone_id: str
    status: DroneStatus = DroneStatus.ONLINE
    first_seen: float = Field(description="wall time (unix s) of the first heartbeat")
    last_seen: float = Field(description="wall time (unix s) of the last heartbeat")
    heartbeat_interval_s: float = Field(
        description="wall seconds between heartbeats: the declared interval at the drone's rate"
    )
    declared_interval_s: float | None = Field(
        default=None, description="the interval the drone declares (vehicle seconds)"
    )
    heartbeat: dict[str, Any] = Field(description="the last heartbeat as the drone sent it")
    specs: dict[str, Any] | None = None
    sensors: dict[str, Any] | None = None
    gear_updated: float | None = None
    status_changed: float | None = None

    model_config = ConfigDict(extra="ignore")

    # Not kept: the ground's awake time of the last heartbeat (the clock starts at each start)
    # and the last stamps and rates that give the drone's clock rate.
    _heard_awake_s: float = PrivateAttr(default=0.0)
    _last_stamps: tuple[float, float] | None = PrivateAttr(default=None)
    _rates: deque[float] = PrivateAttr(default_factory=lambda: deque(maxlen=RATE_PAIRS))
    # The position its telemetry (5 Hz) last gave, newer than a heartbeat's (every 5 s): what
    # the API answers as ``position`` (issue 29: a drone reported 12 m up showed 6 m in REST).
    _tracked: tuple[float, dict[str, float]] | None = PrivateAttr(default=None)
    # The hot paths (a telemetry message's track, the liveness walk, the fleet list) read and
    # write these through :func:`_private`: pydantic finds a private attribute only after the
    # normal lookup failed, 3.7 µs a read against 0.08 (issue 27, 1000 drones at 5 Hz).

    @classmethod
    def first(cls, hb: Heartbeat, now: float, awake_s: float = 0.0) -> DroneRecord:
        record = cls(
            drone_id=hb.drone_id,
            first_seen=now,
            last_seen=now,
            heartbeat_interval_s=_bounded(hb.interval_s),
            declared_interval_s=hb.interval_s,
            heartbeat=hb.model_dump(mode="json", exclude_none=True),
            status=DroneStatus.ONLINE if hb.autopilot_link else DroneStatus.AUTOPILOT_LINK_LOST,
            status_changed=now,
        )
        record._learn_rate(hb)
        record._heard_awake_s = awake_s
        return record

    @classmethod
    def loaded(cls, data: dict[str, Any]) -> DroneRecord:
        """A record as the state store kept it: its drone's clock rate is not known again until
        two heartbeats have come, so until then its declared interval counts as wall time (a
        record of an older ground may hold an interval learned down to nothing)."""
        record = cls.model_validate(data)
        declared = record.declared_interval_s or record.heartbeat.get("interval_s")
        if isinstance(declared, int | float) and declared > 0:
            record.heartbeat_interval_s = _bounded(float(declared))
        return record

    def observe(self, hb: Heartbeat, now: float, awake_s: float | None = None) -> bool:
        """Take a new heartbeat (processed at wall time ``now``, ground awake time ``awake_s``);
        return True if the drone came back from ``lost``."""
        came_back = self.status is DroneStatus.LOST
        self._learn_rate(hb)
        self.declared_interval_s = hb.interval_s
        rate = self.clock_rate  # until it is known, the declared interval is taken as wall time
        self.heartbeat_interval_s = _bounded(hb.interval_s / (rate or 1.0))
        self.last_seen = now
        self._heard_awake_s = self._heard_awake_s if awake_s is None else awake_s
        self.heartbeat = hb.model_dump(mode="json", exclude_none=True)
        status = DroneStatus.ONLINE if hb.autopilot_link else DroneStatus.AUTOPILOT_LINK_LOST
        if status is not self.status:
            self.status = status
            self.status_changed = now
        return came_back

    def _learn_rate(self, hb: Heartbeat) -> None:
        """One more pair of stamps (vehicle time, the sender's wall time) for the clock rate."""
        stamps = (hb.vehicle_time_s, hb.timestamp)
        last, self._last_stamps = self._last_stamps, stamps
        if last is None:
            return
        dv, dt = stamps[0] - last[0], stamps[1] - last[1]
        if dv <= 0 or dt < MIN_PAIR_S:
            return  # a restarted drone, a clock stepped back, or a pair too close to tell
        self._rates.append(dv / dt)

    @property
    def clock_rate(self) -> float | None:
        """The drone's vehicle seconds per wall second, from its own stamps (None: not known)."""
        return statistics.median(self._rates) if self._rates else None

    def lost_after_s(self, min_lost_after_s: float = MIN_LOST_AFTER_S) -> float:
        """Awake seconds of silence after which the drone is lost.

        Never sooner than ``min_lost_after_s`` (``dronefleet ground --lost-after``): a drone
        simulated many times faster than real time beats every fraction of a second, and a link
        known to be lossy may want longer.
        """
        return max(LOST_AFTER_INTERVALS * self.heartbeat_interval_s, min_lost_after_s)

    def heard_at(self, awake_s: float) -> None:
        """Count the drone's silence from ``awake_s`` (the ground started listening then)."""
        self._heard_awake_s = awake_s

    def silent_s(self, awake_s: float) -> float:
        """Awake seconds since the drone was last heard (or since the ground started listening)."""
        return max(0.0, awake_s - _private(self)["_heard_awake_s"])

    def due_at(self, min_lost_after_s: float = MIN_LOST_AFTER_S) -> float:
        """The awake time at which the drone, unheard until then, is due to be lost."""
        return _private(self)["_heard_awake_s"] + self.lost_after_s(min_lost_after_s)

    def due(self, awake_s: float, min_lost_after_s: float = MIN_LOST_AFTER_S) -> bool:
        """Whether the drone, not lost yet, has been silent long enough to be."""
        return self.status is not DroneStatus.LOST and self.silent_s(awake_s) >= self.lost_after_s(
            min_lost_after_s
        )

    def seen_ago_s(self, now: float | None = None) -> float:
        return (timestamp_s() if now is None else now) - self.last_seen

    def track(self, vehicle_time_s: float, fields: dict[str, float]) -> None:
        """A telemetry message's position, if it has one (lat, lon and alt_m at least)."""
        if "lat" in fields and "lon" in fields and "alt_m" in fields:
            # The message's own fields, kept as they are (no copy per message, issue 27):
            # position() takes the position's from them when it is asked.
            _private(self)["_tracked"] = (vehicle_time_s, fields)

    def position(self) -> Any:
        """The newest position: from telemetry when newer than the last heartbeat's."""
        beat = self.heartbeat.get("position")
        tracked = _private(self)["_tracked"]
        if tracked is None or tracked[0] < self.heartbeat.get("vehicle_time_s", 0.0):
            return beat
        fields = tracked[1]
        return {**(beat or {}), **{k: fields[k] for k in _POSITION_KEYS if k in fields}}

    def public(self, min_lost_after_s: float = MIN_LOST_AFTER_S) -> dict[str, Any]:
        """The JSON shape every API answer uses (seed Fig. 4.21, plus liveness)."""
        hb = self.heartbeat
        return {
            "drone_id": self.drone_id,
            "status": self.status.value,
            "last_seen": self.last_seen,
            "seen_ago_s": round(self.seen_ago_s(), 3),
            "first_seen": self.first_seen,
            "heartbeat_interval_s": round(self.heartbeat_interval_s, 4),
            "lost_after_s": round(self.lost_after_s(min_lost_after_s), 4),
            "position": self.position(),
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
            "link_failsafe": hb.get("link_failsafe"),
            "vehicle_time_s": hb.get("vehicle_time_s"),
            "specs": self.specs,
            "sensors": self.sensors,
        }


def _bounded(interval_s: float) -> float:
    return min(max(interval_s, MIN_INTERVAL_S), MAX_INTERVAL_S)
