"""Virtual time (issue 9): the loop's clock moves only when every task waits.

Work, executor jobs and socket hops take zero virtual seconds; timers fire at exactly their
virtual deadline; a finite speed-up never lets virtual time run ahead of the wall clock.
"""

from __future__ import annotations

import asyncio
import itertools
import math
import time

import pytest

from dronefleet import virtual_loop
from dronefleet.clock import monotonic, timestamp_s
from dronefleet.virtual_loop import VirtualTimeLoop, parse_speedup


def test_a_long_sleep_lands_on_its_exact_virtual_deadline_without_the_wall_wait():
    async def main() -> tuple[float, float]:
        loop = asyncio.get_running_loop()
        t0 = loop.time()
        await asyncio.sleep(3600.0)
        return t0, loop.time()

    wall0 = time.monotonic()
    t0, t1 = virtual_loop.run(main())
    assert t1 - t0 == pytest.approx(3600.0, abs=1e-6)
    assert time.monotonic() - wall0 < 600  # an hour of vehicle time did not take an hour


def test_time_stands_still_while_the_cpu_works():
    async def main() -> float:
        loop = asyncio.get_running_loop()
        t0 = loop.time()
        deadline = time.monotonic() + 0.1
        while time.monotonic() < deadline:  # 100 ms of real work, no await
            pass
        await asyncio.sleep(0)
        return loop.time() - t0

    assert virtual_loop.run(main()) == 0.0


def test_an_executor_job_takes_zero_virtual_time_and_holds_every_timer():
    order: list[str] = []

    async def sleeper() -> None:
        await asyncio.sleep(0.01)
        order.append("timer")

    async def main() -> float:
        loop = asyncio.get_running_loop()
        t0 = loop.time()
        timer = asyncio.create_task(sleeper())
        await loop.run_in_executor(None, time.sleep, 0.2)  # 0.2 wall s in a thread
        order.append("job")
        elapsed = loop.time() - t0
        await timer
        return elapsed

    assert virtual_loop.run(main()) == 0.0
    assert order == ["job", "timer"]  # the 10 ms timer did not fire during 200 ms of work


def test_a_socket_round_trip_takes_zero_virtual_time():
    async def echo(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        writer.write(await reader.readexactly(5))
        await writer.drain()
        writer.close()

    async def main() -> tuple[bytes, float]:
        loop = asyncio.get_running_loop()
        server = await asyncio.start_server(echo, "127.0.0.1", 0)
        port = server.sockets[0].getsockname()[1]
        t0 = loop.time()
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        writer.write(b"hello")
        answer = await reader.readexactly(5)
        elapsed = loop.time() - t0
        writer.close()
        server.close()
        await server.wait_closed()
        return answer, elapsed

    answer, elapsed = virtual_loop.run(main())
    assert answer == b"hello"
    assert elapsed == 0.0


def test_timeouts_fire_at_their_virtual_deadline():
    async def main() -> float:
        loop = asyncio.get_running_loop()
        t0 = loop.time()
        with pytest.raises(TimeoutError):
            async with asyncio.timeout(5.0):
                await asyncio.Event().wait()
        return loop.time() - t0

    assert virtual_loop.run(main()) == pytest.approx(5.0, abs=1e-6)


def test_a_finite_speedup_never_runs_ahead_of_the_wall_clock():
    async def main() -> None:
        await asyncio.sleep(1.0)

    wall0 = time.monotonic()
    virtual_loop.run(main(), speedup=10.0)
    assert time.monotonic() - wall0 >= 0.1 - 0.005  # 1 vehicle s at 10x: at least 0.1 wall s


def test_every_timestamp_follows_the_loop_clock():
    async def main() -> tuple[float, float]:
        m0, s0 = monotonic(), timestamp_s()
        await asyncio.sleep(250.0)
        return monotonic() - m0, timestamp_s() - s0

    d_mono, d_stamp = virtual_loop.run(main())
    assert d_mono == pytest.approx(250.0, abs=1e-6)
    assert d_stamp == pytest.approx(250.0, abs=1e-3)


@pytest.mark.virtual_time
async def test_a_marked_test_runs_on_virtual_time():
    assert isinstance(asyncio.get_running_loop(), VirtualTimeLoop)
    t0 = monotonic()
    await asyncio.sleep(60.0)
    assert monotonic() - t0 == pytest.approx(60.0, abs=1e-6)


def test_speedup_values():
    assert parse_speedup("max") == math.inf
    assert parse_speedup("12.5") == 12.5
    for bad in ("0", "-1", "nan", "fast"):
        with pytest.raises(ValueError, match="--speedup"):
            parse_speedup(bad)


def test_a_wall_timer_fires_while_virtual_time_stands_still():
    """A thread works for the loop for 0.6 wall s: virtual time stands still, virtual timers
    wait, and the wall timers (the broker links' keepalive) fire on the wall's schedule."""

    async def main() -> tuple[list[float], float, bool]:
        loop = asyncio.get_running_loop()
        fired: list[float] = []
        wall0 = time.monotonic()
        ticks = virtual_loop.every_wall_s(0.1, lambda: fired.append(time.monotonic() - wall0))
        gone = loop.call_wall_later(0.05, lambda: fired.append(-1.0))
        gone.cancel()
        t0 = loop.time()
        await virtual_loop.held(asyncio.to_thread(time.sleep, 0.6))
        still = loop.time() - t0
        assert ticks is not None
        ticks.cancel()
        count = len(fired)
        await asyncio.sleep(0.3)  # cancelled: no more
        return fired, still, len(fired) == count

    fired, still, stopped = virtual_loop.run(main(), speedup=5.0)
    assert still < 0.05, still
    assert -1.0 not in fired  # the cancelled one never ran
    assert 4 <= len(fired) <= 7, fired
    assert all(b > a for a, b in itertools.pairwise(fired))
    assert stopped


def test_wall_timers_are_the_loops_own_timers_on_an_ordinary_loop():
    async def main() -> object:
        return virtual_loop.every_wall_s(1.0, lambda: None)

    assert asyncio.run(main()) is None
