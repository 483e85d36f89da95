"""The vehicle clock of a UAVTalk autopilot follows SystemStats.FlightTime (docs/DESIGN.md §4); it
is the one estimator every backend uses (drone/fc/clock.py)."""

from __future__ import annotations

import asyncio
import time

import pytest

from dronefleet.clock import Clock
from dronefleet.drone.fc import clock as fc_clock
from dronefleet.drone.fc.clock import AutopilotClock as LinkClock
from dronefleet.protocols.uavtalk.address import parse_tcp_url


async def feed(clock: LinkClock, start_s: float, rate: float, wall_s: float) -> float:
    """Stamps every 10 ms of wall time for ``wall_s``; the last one."""
    wall0 = time.monotonic()
    stamp = start_s
    while (elapsed := time.monotonic() - wall0) < wall_s:
        stamp = start_s + elapsed * rate
        clock.observe_s(stamp)
        await asyncio.sleep(0.01)
    return stamp


async def test_clock_learns_the_autopilots_rate_and_runs_on_between_samples():
    clock = LinkClock()
    assert isinstance(clock, Clock)
    assert clock.now() == 0.0 and not clock.synced
    last = await feed(clock, 100.0, 20.0, 0.3)
    assert clock.speedup == pytest.approx(20.0, rel=0.2)
    before = clock.now()
    assert before == pytest.approx(106.0, abs=0.5)
    await asyncio.sleep(0.05)  # no samples: on at the learnt rate, a few steps at most
    assert before < clock.now() <= last + fc_clock._AHEAD_STEPS * clock._step_s + 1e-9


async def test_sleep_waits_vehicle_seconds():
    clock = LinkClock()
    feeder = asyncio.create_task(feed(clock, 0.0, 20.0, 2.0))
    await asyncio.sleep(0.2)
    wall0, t0 = time.monotonic(), clock.now()
    await clock.sleep(2.0)  # 0.1 wall seconds at 20x
    assert clock.now() - t0 >= 2.0
    assert time.monotonic() - wall0 < 0.5
    feeder.cancel()


async def test_clock_never_runs_backwards_even_when_the_autopilot_reboots():
    clock = LinkClock()
    await feed(clock, 500.0, 1.0, 0.1)
    high = clock.now()
    clock.observe_s(0.5)  # rebooted: FlightTime starts again
    assert clock.now() >= high
    clock.observe_s(0.6)
    assert clock.now() >= high


@pytest.mark.parametrize(
    ("url", "expected"),
    [("tcp:127.0.0.1:9000", ("127.0.0.1", 9000)), ("tcp://localhost:1", ("localhost", 1))],
)
def test_urls(url, expected):
    assert parse_tcp_url(url) == expected


@pytest.mark.parametrize("url", ["udp:1.2.3.4:5", "tcp:host", "127.0.0.1:9000", "tcp::80"])
def test_bad_urls_are_refused(url):
    with pytest.raises(ValueError, match=r"tcp:127\.0\.0\.1:9000"):
        parse_tcp_url(url)
