"""How long a leg takes from the ground's send to its drone's start, in that drone's own vehicle
seconds: the ground's view of the drone (its telemetry's clock when the leg was sent) against
the clock of the drone's ``accepted`` report.

Early replacement (ground/planner/early.py) launches a relief that much sooner. What lies
between a decision and a relief under way is the ground's record write, the broker, the drone's
upload to its autopilot (a MAVLink mission upload is one round trip per item) and its arming,
all in wall time, which a simulated drone flies many times faster: on a loaded CI host a
relief SITL copter at 10x started 13.7 vehicle s after the decision where a quiet host took
2.7, and arrived 6.4 s after the tired one left (the goal is 5). Measured on every leg the
ground sends, the delay is known before the first handover is decided.
"""

from __future__ import annotations

from collections import deque

#: How many of the latest legs' delays are kept; the longest counts.
RECENT = 8
#: The longest delay counted (vehicle s): a leg sent to a drone that was offline for a minute
#: does not make every later relief leave a minute early.
MAX_START_DELAY_S = 30.0


class StartDelays:
    """Send-to-start delays of the latest legs, in their drones' vehicle seconds."""

    def __init__(self) -> None:
        self._sent: dict[str, float] = {}  # leg id -> its drone's clock when it was sent
        self._recent: deque[float] = deque(maxlen=RECENT)

    def sent(self, leg_id: str, vehicle_time_s: float | None) -> None:
        """``leg_id`` sent now; ``vehicle_time_s``: its drone's latest telemetry clock (None:
        no telemetry yet, so no delay is measured for this leg)."""
        if vehicle_time_s is not None:
            self._sent[leg_id] = vehicle_time_s

    def started(self, leg_id: str, vehicle_time_s: float | None) -> None:
        """``leg_id``'s drone reported it accepted the leg at its ``vehicle_time_s``."""
        sent = self._sent.pop(leg_id, None)
        if sent is None or vehicle_time_s is None or vehicle_time_s < sent:
            return  # not measured, or a drone restarted meanwhile (its clock began again)
        self._recent.append(min(vehicle_time_s - sent, MAX_START_DELAY_S))

    def longest(self) -> float:
        """The longest delay of the latest legs (0 before any leg has started)."""
        return max(self._recent, default=0.0)

    def forget(self, leg_id: str) -> None:
        """``leg_id`` will not start (stopped, failed, or its mission ended)."""
        self._sent.pop(leg_id, None)
