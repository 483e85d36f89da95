"""The autopilot's clock (docs/DESIGN.md §4): vehicle seconds from the autopilot's time since boot
(MAVLink ``time_boot_ms``, UAVTalk ``SystemStats.FlightTime``), one estimator for every backend.

Drone-side waiting (mission ``sleep`` steps, heartbeats, telemetry) must run on the vehicle's time
so that a simulation sped up 20 times still reports its durations in vehicle seconds. The autopilot
stamps most messages with its boot time; this clock interpolates between those stamps at the rate
it observes (vehicle seconds per wall second), so ``now()`` is smooth and ``sleep(d)`` returns once
the autopilot's own time has advanced by ``d``. A reboot restarts ``time_boot_ms`` at zero; the
clock adds the time before the reboot so that its ``now()`` never runs backwards.

Between stamps ``now()`` runs at most :data:`_AHEAD_STEPS` of the autopilot's usual steps
between stamps past the last one: a host that stalls the autopilot (a simulator sharing a loaded
machine) stalls its stamps too, and the clock had run on at the old rate meanwhile, 2.4 vehicle
s ahead of the simulated vehicle after a 0.12 s stall at 20x (CI, the UAVTalk flight test).
Across a silence (the autopilot's link lost: no stamp for :data:`_GAP_WALL_S`) ``now()`` runs on
at the last rate from where it held, and what it said stays said: the first stamp after the
silence takes the clock on from there (issue 26). Before, a reboot made the clock add only the
boot time seen before the silence, so it stood still until the new boot time caught up with what
it had already reported: a drone whose autopilot rebooted mid-flight sent no heartbeat for as
long as the autopilot had been away (heartbeats wait on this clock), and was called lost. A
reboot that is not seen as a step back (the autopilot was away longer than it had been up) is
caught the same way: the stamp after the silence is behind what the clock said.
"""

from __future__ import annotations

import collections

from dronefleet.clock import monotonic, sleep_on_estimate

#: Wall seconds of stamps kept for the rate estimate.
_WINDOW_WALL_S = 3.0
#: Shortest wall span over which a rate is trusted.
_MIN_SPAN_WALL_S = 0.2
#: A stamp this far behind the previous one means the autopilot rebooted.
_REBOOT_JUMP_S = 1.0
#: ... and once a reboot was commanded (stamps never go back by more than jitter otherwise).
_EXPECTED_JUMP_S = 0.01
#: Between stamps, the clock runs at most this many of the autopilot's steps between stamps
#: (their recent largest, :data:`_STEP_DECAY`) past the last one, until a silence.
_AHEAD_STEPS = 3.0
#: Each stamp, the recent largest step shrinks by this factor unless this step is larger.
_STEP_DECAY = 0.99
#: Longest wall sleep between looks at the clock (the rate may change meanwhile).
_MAX_WALL_NAP_S = 0.05
#: No stamp for this long (wall seconds) is a silence: the link was lost, or the autopilot
#: rebooted; the clock ran on meanwhile, and goes on from where it was.
_GAP_WALL_S = 1.5


class AutopilotClock:
    """Vehicle time from boot stamps; satisfies :class:`dronefleet.clock.Clock`."""

    def __init__(self) -> None:
        self._offset_s = 0.0  # boot time accumulated over earlier boots
        self._last_boot_s: float | None = None
        self._last_wall = monotonic()
        self._base_s = 0.0  # clock time at _last_wall
        self._rate = 1.0
        self._samples: collections.deque[tuple[float, float]] = collections.deque()
        self._reported = 0.0
        self._expect_reboot = False
        self._step_s = float("inf")  # the recent largest step between stamps (vehicle s)
        self.boot_count = 0

    @property
    def speedup(self) -> float:
        """Observed vehicle seconds per wall second (1 until enough stamps arrived)."""
        return self._rate

    @property
    def synced(self) -> bool:
        return self._last_boot_s is not None

    def observe(self, time_boot_ms: float, wall: float | None = None) -> None:
        """Take a ``time_boot_ms`` stamp from a message received at ``wall`` (monotonic)."""
        self.observe_s(time_boot_ms / 1000.0, wall)

    def observe_s(self, boot_s: float, wall: float | None = None) -> None:
        """Take a time since boot, in seconds, received at ``wall`` (monotonic)."""
        wall = monotonic() if wall is None else wall
        jump = _EXPECTED_JUMP_S if self._expect_reboot else _REBOOT_JUMP_S
        last = self._last_boot_s
        # What the clock has been saying since the last stamp.
        ran_on = self._said(wall)
        if last is not None and boot_s < last - jump:  # rebooted: boot time starts again
            self._expect_reboot = False
            # On from the time before the reboot, or from where the clock ran on to through
            # a silence, less the boot time since (never back: heartbeats wait on it).
            self._offset_s = max(self._offset_s + last, ran_on - boot_s)
            self._samples.clear()
            self.boot_count += 1
        elif (
            last is not None
            and wall - self._last_wall > _GAP_WALL_S
            and self._offset_s + boot_s < ran_on - _REBOOT_JUMP_S
        ):  # after a silence, behind what was said: on from there
            self._offset_s = ran_on - boot_s
            self._samples.clear()
        if last is not None and boot_s > last:
            step = boot_s - last
            self._step_s = (
                step if self._step_s == float("inf") else max(step, self._step_s * _STEP_DECAY)
            )
        self._last_boot_s = boot_s
        t = self._offset_s + boot_s
        samples = self._samples
        samples.append((wall, t))
        while samples and wall - samples[0][0] > _WINDOW_WALL_S:
            samples.popleft()
        span = wall - samples[0][0]
        if span >= _MIN_SPAN_WALL_S:
            rate = (t - samples[0][1]) / span
            if rate > 0:
                self._rate = min(max(rate, 1e-3), 1e5)
        self._base_s, self._last_wall = t, wall

    def expect_reboot(self) -> None:
        """A reboot was commanded: the next step back in boot time, however small, is it."""
        self._expect_reboot = True

    def now(self) -> float:
        if self._last_boot_s is None:
            return self._reported  # no stamp yet: the vehicle's time is not known to run
        t = self._said(monotonic())
        # Stamps arrive with jitter: never report time running backwards.
        self._reported = max(self._reported, t)
        return self._reported

    def _said(self, wall: float) -> float:
        """The clock's time at ``wall``: the last stamp's, run on at the last rate, at most
        :data:`_AHEAD_STEPS` steps until :data:`_GAP_WALL_S` of silence, then on from there."""
        elapsed = max(0.0, wall - self._last_wall)
        ran = min(min(elapsed, _GAP_WALL_S) * self._rate, _AHEAD_STEPS * self._step_s)
        if elapsed > _GAP_WALL_S:
            ran += (elapsed - _GAP_WALL_S) * self._rate
        return self._base_s + ran

    async def sleep(self, duration_s: float) -> None:
        """Wait until the autopilot's time has advanced by ``duration_s`` vehicle seconds."""
        await sleep_on_estimate(self, duration_s, _MAX_WALL_NAP_S)

    def __repr__(self) -> str:
        return f"AutopilotClock(now={self.now():.3f}s, rate={self._rate:.2f})"
