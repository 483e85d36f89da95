"""How many vehicle physics steps per wall second one SimWorld manages (1 to 1000 vehicles).

Vehicles are armed and cruising (the expensive case); the figure divided by 20 (steps per
vehicle second at the default 0.05 s step) is the real-time speedup a fleet of that size allows.

    .venv/bin/python bench/sim_step.py
"""

from __future__ import annotations

import time

from dronefleet.geo.types import LLA, NED
from dronefleet.sim import SimWorld

HOME = LLA(40.63, -8.658, 10.0)
BUDGET_S = 1.0


def vehicle_steps_per_second(count: int) -> float:
    world = SimWorld()
    # a bottomless battery and a far target keep every vehicle cruising for the whole budget
    fleet = [world.add_vehicle(f"QUAD_{i}", HOME, capacity_mah=1e12) for i in range(count)]
    for vehicle in fleet:
        vehicle.arm()
    world.advance(3.0)
    for i, vehicle in enumerate(fleet):
        vehicle.goto(NED(1e7, 10.0 * i, -20.0))
    world.advance(1.0)  # up to speed
    ticks = 0
    start = time.perf_counter()
    while (elapsed := time.perf_counter() - start) < BUDGET_S:
        world.tick()
        ticks += 1
    return ticks * count / elapsed


def main() -> None:
    print(f"{'vehicles':>8}  {'vehicle-steps/s':>15}  {'max speedup':>11}")
    for count in (1, 10, 100, 1000):
        rate = vehicle_steps_per_second(count)
        speedup = rate / count * 0.05
        print(f"{count:>8}  {rate:>15,.0f}  {speedup:>10,.0f}x")


if __name__ == "__main__":
    main()
