"""The Fail-safe System (seed 3.3.2.4): watches the drone's own telemetry and raises alarms.

It is given the flight samples the Drone Controller reads from the autopilot (``battery_pct``,
``lat``, ``lon``, ``alt_m``, ``relative_alt_m``) and the Gear Manager's sensor samples (e.g.
``co2_ppm``) in process, through :meth:`FailSafe.feed`: it trusts the autopilot and the sensors,
never its own telemetry echoed back by a broker, where five forged messages once made a drone
raise three genuine CRITICAL alarms about itself (issue 12). The seed's way, listening on
``<id>/telemetry/out``, remains for a fail-safe run apart (``listen_to_broker``). It listens to
``<id>/mission/out`` to name the mission and step in its alarms.

* A battery below the critical threshold raises exactly one ``CRITICAL`` alarm: the ground replaces
  the drone. It re-arms only when the battery is back ``battery_rearm_pct`` points above the
  threshold (a battery swap), so a noisy gauge around 20 % does not raise a storm of alarms.
* A sensor reading outside its bounds raises exactly one ``OUT_MEASURE`` alarm per excursion: the
  ground starts a collaborative survey. It re-arms once the reading is back inside its bounds by a
  5 % hysteresis margin (of the band when both bounds are given, else of the bound).

Every alarm carries a position. Until the first position fix arrives, alarms wait (they are sent
with the first fix); afterwards the last known position is used.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any

from dronefleet.clock import Clock
from dronefleet.messaging import topics
from dronefleet.messaging.client import QOS_COMMAND, QOS_STREAM, BrokerClient
from dronefleet.messaging.codec import MessageError
from dronefleet.messaging.commands import AlarmLevel
from dronefleet.messaging.common import Position
from dronefleet.messaging.inbound import parse_message, speaks_for_itself
from dronefleet.messaging.missions import MissionProgress, ProgressEvent
from dronefleet.messaging.status import Alarm, Telemetry
from dronefleet.messaging.topics import Channel, Direction

log = logging.getLogger(__name__)

BATTERY_FIELD = "battery_pct"
HYSTERESIS_FRACTION = 0.05
_MISSION_OVER = frozenset({ProgressEvent.COMPLETED, ProgressEvent.STOPPED, ProgressEvent.FAILED})


@dataclass
class BoundWatch:
    """One field's bounds and whether it is out of them (``side``: ``"low"``/``"high"``/None)."""

    field: str
    low: float | None
    high: float | None
    rearm_margin: float
    side: str | None = None

    def update(self, value: float) -> str | None:
        """Feed one value; return the side of a *new* excursion, else None."""
        if self.low is not None and value < self.low:
            side = "low"
        elif self.high is not None and value > self.high:
            side = "high"
        else:
            side = None
        if side is not None:
            new = side != self.side
            self.side = side
            return side if new else None
        if self.side is not None and self._back_inside(value):
            self.side = None
        return None

    def _back_inside(self, value: float) -> bool:
        """Inside the bounds by at least the re-arm margin."""
        if self.side == "low":
            return self.low is None or value >= self.low + self.rearm_margin
        return self.high is None or value <= self.high - self.rearm_margin


def sensor_watch(field: str, low: float | None, high: float | None) -> BoundWatch:
    """A watch with the 5 % hysteresis margin for a sensor field."""
    if low is not None and high is not None:
        if low > high:
            raise ValueError(f"bounds for {field}: low {low} is above high {high}")
        margin = HYSTERESIS_FRACTION * (high - low)
    else:
        bound = low if low is not None else high
        if bound is None:
            raise ValueError(f"bounds for {field}: give a low bound, a high bound or both")
        margin = HYSTERESIS_FRACTION * abs(bound)
    return BoundWatch(field, low, high, margin)


@dataclass
class _Pending:
    level: AlarmLevel
    message: str
    reading: dict[str, Any]
    vehicle_time_s: float


def _number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    value = float(value)
    return value if math.isfinite(value) else None


class FailSafe:
    """Raises CRITICAL (battery) and OUT_MEASURE (sensor bounds) alarms, once per crossing."""

    def __init__(
        self,
        drone_id: str,
        client: BrokerClient,
        clock: Clock,
        *,
        battery_critical_pct: float = 20.0,
        sensor_bounds: dict[str, tuple[float | None, float | None]] | None = None,
        battery_rearm_pct: float = 5.0,
        listen_to_broker: bool = True,
    ) -> None:
        self.drone_id = topics.check_drone_id(drone_id)
        self.client = client
        self.clock = clock
        self.battery = BoundWatch(BATTERY_FIELD, battery_critical_pct, None, battery_rearm_pct)
        self.sensors = {
            field: sensor_watch(field, low, high)
            for field, (low, high) in (sensor_bounds or {}).items()
        }
        # The last believable fix (lat, lon, alt, relative alt), made a Position only when an
        # alarm needs it: building one per sample was a tenth of a simulated drone's cost.
        self._fix: tuple[float, float, float, float | None] | None = None
        self._position: Position | None = None
        self.mission_id: str | None = None
        self.step_index: int | None = None
        self.alarms_raised = 0
        self._pending: list[_Pending] = []
        self._running = False
        self._subscribed = False
        self.listen_to_broker = listen_to_broker
        self._telemetry_topic = topics.topic(drone_id, Channel.TELEMETRY, Direction.OUT)
        self._mission_topic = topics.topic(drone_id, Channel.MISSION, Direction.OUT)
        self._alarm_topic = topics.topic(drone_id, Channel.ALARMS, Direction.OUT)

    async def start(self) -> None:
        self._running = True
        if not self._subscribed:
            if self.listen_to_broker:
                await self.client.subscribe(
                    self._telemetry_topic, self._on_telemetry, qos=QOS_STREAM
                )
            await self.client.subscribe(self._mission_topic, self._on_mission, qos=QOS_COMMAND)
            self._subscribed = True

    async def stop(self) -> None:
        self._running = False

    # -- inputs ------------------------------------------------------------------------------
    async def _on_mission(self, topic_name: str, payload: bytes) -> None:
        try:
            progress = parse_message(MissionProgress, payload)
            speaks_for_itself(topic_name, progress.drone_id)
        except MessageError:
            return  # not a progress report of this drone's (the ground's requests share no topic)
        if progress.event is ProgressEvent.REJECTED:
            return  # nothing changed on board
        if progress.event in _MISSION_OVER:
            self.mission_id, self.step_index = None, None
            return
        self.mission_id, self.step_index = progress.mission_id, progress.step_index

    async def _on_telemetry(self, topic_name: str, payload: bytes) -> None:
        if not self._running:
            return
        try:
            telemetry = parse_message(Telemetry, payload)
            speaks_for_itself(topic_name, telemetry.drone_id)
        except MessageError as exc:
            log.debug("fail-safe: dropping telemetry: %s", exc)
            return
        self.observe(telemetry.fields, telemetry.vehicle_time_s)
        await self._flush()

    async def feed(self, fields: dict[str, Any], vehicle_time_s: float) -> None:
        """A sample read on board (flight or sensors); raise what it calls for."""
        if not self._running:
            return
        self.observe(fields, vehicle_time_s)
        await self._flush()

    def observe(self, fields: dict[str, Any], vehicle_time_s: float) -> None:
        """Take one telemetry field map into account; queue any alarm it raises."""
        self._update_position(fields)
        battery = _number(fields.get(BATTERY_FIELD))
        if battery is not None and self.battery.update(battery) is not None:
            threshold = self.battery.low
            self._pending.append(
                _Pending(
                    AlarmLevel.CRITICAL,
                    f"battery {battery:.1f}% below {threshold:g}% threshold",
                    {"field": BATTERY_FIELD, "value": battery, "low": threshold, "high": None},
                    vehicle_time_s,
                )
            )
        for field, watch in self.sensors.items():
            value = _number(fields.get(field))
            side = None if value is None else watch.update(value)
            if side is None:
                continue
            bound = watch.low if side == "low" else watch.high
            where = "below" if side == "low" else "above"
            self._pending.append(
                _Pending(
                    AlarmLevel.OUT_MEASURE,
                    f"{field} {value:g} {where} its {side} bound {bound:g}",
                    {"field": field, "value": value, "low": watch.low, "high": watch.high},
                    vehicle_time_s,
                )
            )

    @property
    def position(self) -> Position | None:
        """The last known position (None before the first fix)."""
        if self._position is None and self._fix is not None:
            lat, lon, alt, relative = self._fix
            self._position = Position(lat=lat, lon=lon, alt_m=alt, relative_alt_m=relative)
        return self._position

    def _update_position(self, fields: dict[str, Any]) -> None:
        lat, lon, alt = _number(fields.get("lat")), _number(fields.get("lon")), None
        if lat is None or lon is None or (alt := _number(fields.get("alt_m"))) is None:
            return
        # Position's own bounds, checked here so a Position is built only when needed.
        if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0 and -500.0 <= alt <= 10_000.0):
            log.debug("fail-safe: ignoring an impossible position %s, %s, %s", lat, lon, alt)
            return
        self._fix = (lat, lon, alt, _number(fields.get("relative_alt_m")))
        self._position = None

    # -- output ------------------------------------------------------------------------------
    async def _flush(self) -> None:
        if not self._pending or self.position is None:
            return  # alarms wait for the first position fix
        pending, self._pending = self._pending, []
        for item in pending:
            alarm = Alarm(
                drone_id=self.drone_id,
                level=item.level,
                message=item.message,
                position=self.position,
                reading=item.reading,
                mission_id=self.mission_id,
                step_index=self.step_index,
                vehicle_time_s=item.vehicle_time_s,
            )
            log.warning("fail-safe alarm %s on %s: %s", item.level, self.drone_id, item.message)
            self.alarms_raised += 1
            await self.client.publish(self._alarm_topic, alarm, qos=QOS_COMMAND)
