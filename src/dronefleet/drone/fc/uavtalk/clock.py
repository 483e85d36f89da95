"""The vehicle clock of a UAVTalk flight controller (docs/DESIGN.md §4).

Drone-side code takes its time from the vehicle: here the autopilot's time since boot, which the
flight side sends in ``SystemStats.FlightTime`` ten times a second. Between samples the clock runs
on at the rate it has observed (vehicle seconds per wall second), so a simulator running 20 times
faster than real time gives the Drone Controller, Mission Worker and Gear Manager 20 times faster
heartbeats, timeouts and waits, all in vehicle seconds. The clock never runs backwards; if the
autopilot's time does (a reboot), the clock holds until the new time catches up.
"""

from __future__ import annotations

from collections import deque

from dronefleet.clock import monotonic, sleep_on_estimate

#: Wall seconds of samples the rate estimate looks back over.
_RATE_WINDOW_WALL_S = 2.0
#: Longest wall wait between re-checks while sleeping (new samples may change the rate).
_MAX_WAIT_WALL_S = 0.05


class LinkClock:
    """Satisfies :class:`dronefleet.clock.Clock` from observed vehicle timestamps."""

    def __init__(self) -> None:
        self._samples: deque[tuple[float, float]] = deque()  # (wall, vehicle)
        self._rate = 1.0
        self._floor = 0.0  # never report less than what was already reported
        self._offset = 0.0  # added after a reboot so time stays monotonic

    def observe(self, vehicle_s: float) -> None:
        """Feed one vehicle timestamp (seconds since the autopilot booted)."""
        wall = monotonic()
        if self._samples and vehicle_s + self._offset < self._samples[-1][1] - 1.0:
            self._offset = self._samples[-1][1] - vehicle_s  # rebooted: continue from here
            self._samples.clear()
        vehicle = vehicle_s + self._offset
        self._samples.append((wall, vehicle))
        while self._samples and wall - self._samples[0][0] > _RATE_WINDOW_WALL_S:
            self._samples.popleft()
        first_wall, first_vehicle = self._samples[0]
        if wall - first_wall > 0.05 and vehicle > first_vehicle:
            self._rate = (vehicle - first_vehicle) / (wall - first_wall)

    @property
    def synced(self) -> bool:
        return bool(self._samples)

    def now(self) -> float:
        if not self._samples:
            return self._floor
        wall, vehicle = self._samples[-1]
        estimate = vehicle + (monotonic() - wall) * self._rate
        self._floor = max(self._floor, estimate)
        return self._floor

    @property
    def speedup(self) -> float:
        return self._rate

    async def sleep(self, duration_s: float) -> None:
        await sleep_on_estimate(self, duration_s, _MAX_WAIT_WALL_S)
