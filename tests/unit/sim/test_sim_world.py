"""One world, one clock, many vehicles: sim time runs N times faster than wall time."""

from __future__ import annotations

import asyncio
import time

import pytest

from dronefleet.clock import Clock
from dronefleet.geo.types import LLA, NED
from dronefleet.sim import SimClock, SimWorld


async def test_the_sim_clock_is_a_clock_that_only_moves_when_advanced() -> None:
    clock = SimClock(speedup=5)
    assert isinstance(clock, Clock)
    assert clock.now() == 0.0 and clock.speedup == 5
    woke: list[float] = []

    async def sleeper() -> None:
        await clock.sleep(0.3)
        woke.append(clock.now())

    task = asyncio.create_task(sleeper())
    await asyncio.sleep(0)
    for _ in range(5):
        clock.advance(0.05)
    await asyncio.sleep(0)
    assert woke == []
    clock.advance(0.05)  # 6 x 0.05 is 0.30000000000000004: still due
    await task
    assert woke == [pytest.approx(0.3)]


async def test_a_world_at_speedup_20_runs_many_vehicle_seconds_per_wall_second(home) -> None:
    async with SimWorld(speedup=20) as world:
        wall_start = time.monotonic()
        await world.clock.sleep(10.0)
        wall = time.monotonic() - wall_start
    assert world.clock.now() == pytest.approx(10.0, abs=0.06)
    assert 10.0 / wall >= 5  # loosely: shared machines are noisy
    assert 10.0 / wall <= 25  # and it is paced, not flat out


async def test_sleepers_wake_in_deadline_order_at_their_sim_time() -> None:
    order: list[tuple[str, float]] = []
    async with SimWorld(speedup=50) as world:

        async def sleeper(name: str, duration_s: float) -> None:
            await world.clock.sleep(duration_s)
            order.append((name, world.clock.now()))

        await asyncio.gather(
            sleeper("c", 1.5), sleeper("a", 0.5), sleeper("b", 1.0), sleeper("a2", 0.5)
        )
    assert [name for name, _ in order] == ["a", "a2", "b", "c"]
    for (_, woke_at), deadline in zip(order, (0.5, 0.5, 1.0, 1.5), strict=True):
        assert woke_at == pytest.approx(deadline, abs=0.051)


async def test_fifty_vehicles_fly_in_one_world(home: LLA) -> None:
    world = SimWorld(speedup=1000)
    fleet = [world.add_vehicle(f"QUAD_{i}", home) for i in range(50)]
    for v in fleet:
        v.arm()
    async with world:
        await world.clock.sleep(3.1)
        assert all(v.armed for v in fleet)
        for i, v in enumerate(fleet):
            v.goto(NED(2.0 * i, 50.0, -10.0))
        await world.clock.sleep(20.0)
    for i, v in enumerate(fleet):
        assert v.position_ned == NED(2.0 * i, 50.0, -10.0)
        assert v.time_s == pytest.approx(world.clock.now())


def test_a_world_can_be_stepped_without_its_loop(home: LLA) -> None:
    world = SimWorld()
    quad = world.add_vehicle("QUAD_1", home, initial_charge_pct=30)
    quad.arm()
    world.advance(3.0)
    assert quad.armed and world.clock.now() == pytest.approx(3.0)
    assert quad.battery_state.remaining_pct < 30
    with pytest.raises(ValueError, match="already exists"):
        world.add_vehicle("QUAD_1", home)


async def test_a_vehicle_added_later_shares_the_world_time(home: LLA) -> None:
    world = SimWorld()
    world.advance(5.0)
    late = world.add_vehicle("LATE", home)
    world.advance(1.0)
    assert late.time_s == pytest.approx(world.clock.now())
