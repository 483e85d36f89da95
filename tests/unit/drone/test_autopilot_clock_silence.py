"""The autopilot's clock across a silence and a reboot (issue 26, item 5).

Before: an autopilot away for 20 s that came back rebooted left the clock standing still for
those 20 s (it had reported them already and took the new boot time on from before the silence),
so the drone's heartbeats, which wait on it, stopped and the ground called the drone lost.

Across a silence the clock holds a few of the autopilot's steps past its last stamp for
``_GAP_WALL_S`` (a stalled host, not yet a silence), then runs on from there at the last rate.
"""

from __future__ import annotations

import pytest

from dronefleet.drone.fc import clock as fc_clock
from dronefleet.drone.fc.clock import AutopilotClock


class Wall:
    def __init__(self) -> None:
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t


@pytest.fixture
def wall(monkeypatch) -> Wall:
    wall = Wall()
    monkeypatch.setattr(fc_clock, "monotonic", wall)
    return wall


def stamps(clock: AutopilotClock, wall: Wall, boot_s: float, seconds: float) -> float:
    """The autopilot talks for ``seconds`` (10 stamps a second, at 1 vehicle s per wall s)."""
    for _ in range(int(seconds * 10)):
        clock.observe_s(boot_s, wall.t)
        boot_s += 0.1
        wall.t += 0.1
    return boot_s


@pytest.mark.parametrize("up_s", [60.0, 5.0], ids=["up longer than away", "away longer than up"])
def test_after_a_silence_and_a_reboot_the_clock_runs_on_at_once(wall, up_s):
    clock = AutopilotClock()
    stamps(clock, wall, 0.0, up_s)
    wall.t += 20.0  # the autopilot is away 20 s: no stamp
    during = clock.now()
    held = fc_clock._AHEAD_STEPS * 0.1  # three of its 0.1 s steps, for the first 1.5 s
    ran = up_s + held + 20.0 - fc_clock._GAP_WALL_S
    assert during == pytest.approx(ran, abs=0.2)  # it ran on meanwhile
    # Back, rebooted 15 s ago (its boot time says so).
    stamps(clock, wall, 15.0, 0.1)
    after = clock.now()
    stamps(clock, wall, 15.1, 1.0)
    assert clock.now() - after == pytest.approx(1.0, abs=0.1), "the clock stood still"
    assert after >= during  # and never went back
    stamps(clock, wall, 16.1, 2.0)
    assert clock.now() == pytest.approx(ran + 3.1, abs=0.3)


def test_a_quick_reboot_goes_on_from_before_it_as_it_did(wall):
    clock = AutopilotClock()
    boot = stamps(clock, wall, 0.0, 30.0)
    stamps(clock, wall, 0.2, 0.5)  # rebooted, no silence to speak of
    assert clock.boot_count == 1
    assert clock.now() == pytest.approx(boot + 0.6, abs=0.2)


def test_a_stall_shorter_than_a_silence_holds_the_clock_a_few_steps_past_the_last_stamp(wall):
    """A host that stalls the autopilot stalls its stamps: the clock ran on at the old rate, 2.4
    vehicle s past the simulated vehicle after a 0.12 s stall at 20x (CI)."""
    clock = AutopilotClock()
    boot = 0.0
    for _ in range(100):  # 20x: a 0.1 s step every 5 ms
        clock.observe_s(boot, wall.t)
        boot += 0.1
        wall.t += 0.005
    last = boot - 0.1
    wall.t += 0.12  # stalled
    assert clock.now() == pytest.approx(last + fc_clock._AHEAD_STEPS * 0.1)
    wall.t += 1.0  # still within what is not yet a silence
    assert clock.now() == pytest.approx(last + fc_clock._AHEAD_STEPS * 0.1)
    clock.observe_s(last + 0.1, wall.t)  # back: behind what it said, so it holds till caught up
    said = clock.now()
    assert said == pytest.approx(last + fc_clock._AHEAD_STEPS * 0.1)
    clock.observe_s(last + 0.5, wall.t + 0.02)
    wall.t += 0.02
    assert clock.now() == pytest.approx(last + 0.5) and clock.now() >= said


def test_jitter_without_a_silence_changes_nothing(wall):
    clock = AutopilotClock()
    stamps(clock, wall, 0.0, 10.0)
    said = clock.now()
    clock.observe_s(9.95, wall.t)  # a late stamp, a little behind
    assert clock.now() >= said and clock.boot_count == 0
    stamps(clock, wall, 10.1, 1.0)
    assert clock.now() == pytest.approx(11.0, abs=0.2)
