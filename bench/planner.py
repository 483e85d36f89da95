"""How long the Mission Planner takes to plan an area, estimate it and share it among drones.

Areas of 1e3, 1e4 and 1e5 m² (a concave field with a pond, automatic angle, 8 m spacing),
stopping at every waypoint and flying through; then the split of the 1e4 and 1e5 m² routes
among 2 to 5 drones (every order of drones tried; batteries unlimited here).

    .venv/bin/python bench/planner.py
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

from dronefleet.geo.ned import LocalFrame
from dronefleet.geo.types import LLA, NED
from dronefleet.ground.planner.allocation import DroneSlot, makespan_s, split_route
from dronefleet.ground.planner.coverage import AreaSpec, CoveragePlan, plan_area
from dronefleet.ground.planner.estimate import VehicleModel, estimate

#: Splits are timed without the battery limit (1e5 m² takes more than five packs).
UNLIMITED = VehicleModel(capacity_mah=1e9)

ORIGIN = LLA(40.63, -8.658, 5.0)
FRAME = LocalFrame(ORIGIN)
SPACING_M = 8.0


def latlon(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    return [(p.lat, p.lon) for p in (FRAME.to_lla(NED(n, e)) for e, n in points)]


def field(area_m2: float, fly_through: bool) -> AreaSpec:
    """An L-shaped field with a square pond, scaled to ``area_m2``."""
    outer = [(0, 0), (100, 0), (100, 60), (60, 60), (60, 100), (0, 100)]
    pond = [(20, 20), (35, 20), (35, 35), (20, 35)]
    k = math.sqrt(area_m2 / (100 * 100 - 40 * 40 - 15 * 15))
    return AreaSpec(
        polygon=latlon([(x * k, y * k) for x, y in outer]),
        holes=[latlon([(x * k, y * k) for x, y in pond])],
        spacing_m=SPACING_M,
        action="takepic",
        fly_through=fly_through,
    )


def timed(fn: Callable[[], Any], repeat: int = 3) -> tuple[float, Any]:
    best, result = math.inf, None
    for _ in range(repeat):
        start = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - start)
    return best, result


def team(count: int) -> list[DroneSlot]:
    slots = [DroneSlot("D0", FRAME.to_lla(NED(0, 0, -10)), True, 100.0, ORIGIN)]
    for i in range(1, count):
        here = FRAME.to_lla(NED(-30.0 * i, 20.0 * i))
        slots.append(DroneSlot(f"D{i}", here, False, 100.0, here))
    return slots


def main() -> None:
    print(
        f"{'area m²':>8} {'mode':>12} {'waypoints':>9} {'plan ms':>8} {'estimate ms':>11}"
        f" {'flight s':>8}"
    )
    plans: dict[float, CoveragePlan] = {}
    for area in (1e3, 1e4, 1e5):
        for fly in (False, True):
            plan_s, plan = timed(lambda a=area, f=fly: plan_area(field(a, f)))
            steps = plan.mission_steps()
            start = plan.waypoints[0]
            est_s, est = timed(
                lambda s=steps, p=start: estimate(
                    s, LLA(p.lat, p.lon, ORIGIN.alt_m + 10), ORIGIN, airborne=True
                )
            )
            mode = "fly-through" if fly else "stop"
            print(
                f"{area:>8.0e} {mode:>12} {len(plan.waypoints):>9} {plan_s * 1e3:>8.1f}"
                f" {est_s * 1e3:>11.1f} {est.duration_s:>8.0f}"
            )
            if not fly:
                plans[area] = plan
    print()
    print(f"{'area m²':>8} {'drones':>6} {'split ms':>8} {'makespan s':>10}")
    for area in (1e4, 1e5):
        for count in (2, 3, 4, 5):
            split_s, shares = timed(
                lambda p=plans[area], c=count: split_route(p, team(c), model=UNLIMITED), repeat=1
            )
            print(f"{area:>8.0e} {count:>6} {split_s * 1e3:>8.1f} {makespan_s(shares):>10.0f}")


if __name__ == "__main__":
    main()
