"""How long the Mission Planner takes to plan an area, estimate it and share it among drones.

First the figures of issue 11 ("planning fast enough for a fleet"): the 1 km² field at 10 m
spacing planned and shared among 10 drones, stopping at every waypoint and flying through
(target: plan + split within 200 ms each), and three worst-case 2000-vertex areas — a circle, a
comb and a gear with 1000 spikes — planned with the automatic angle (target: 2 s each).

Then areas of 1e3, 1e4 and 1e5 m² (a concave field with a pond, automatic angle, 8 m spacing),
stopping at every waypoint and flying through; then the split of the 1e4 and 1e5 m² routes
among 2 to 5 drones (every order of drones tried; batteries unlimited here).

    .venv/bin/python bench/planner.py            # everything
    .venv/bin/python bench/planner.py fleet      # only issue 11's figures (or: field, worst)
"""

from __future__ import annotations

import math
import sys
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


def field(area_m2: float, fly_through: bool, spacing_m: float = SPACING_M) -> AreaSpec:
    """An L-shaped field with a square pond, scaled to ``area_m2``."""
    outer = [(0, 0), (100, 0), (100, 60), (60, 60), (60, 100), (0, 100)]
    pond = [(20, 20), (35, 20), (35, 35), (20, 35)]
    k = math.sqrt(area_m2 / (100 * 100 - 40 * 40 - 15 * 15))
    return AreaSpec(
        polygon=latlon([(x * k, y * k) for x, y in outer]),
        holes=[latlon([(x * k, y * k) for x, y in pond])],
        spacing_m=spacing_m,
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


# -- issue 11: a fleet's field and worst-case outlines ----------------------------------------
def circle(n: int = 2000, radius: float = 300.0) -> list[tuple[float, float]]:
    """A 300 m circle drawn with ``n`` vertices (a traced outline: far more than it needs)."""
    return [
        (radius * math.cos(2 * math.pi * k / n), radius * math.sin(2 * math.pi * k / n))
        for k in range(n)
    ]


def gear(n: int = 2000, radius: float = 300.0, depth: float = 15.0) -> list[tuple[float, float]]:
    """A 300 m disc with n/2 spikes 15 m deep and 1.9 m wide at the base."""
    out = []
    for k in range(n):
        r = radius + depth * (k % 2)
        out.append((r * math.cos(2 * math.pi * k / n), r * math.sin(2 * math.pi * k / n)))
    return out


def comb(n: int = 2000) -> list[tuple[float, float]]:
    """A 30-40 m deep back with (n - 4) / 4 teeth 3 m wide, 3 m apart and 40 m long."""
    teeth, pitch, tooth, base, length = (n - 4) // 4, 6.0, 3.0, 30.0, 40.0
    width = teeth * pitch  # the back's underside is bevelled: 4 vertices
    out = [(0.0, 0.0), (width / 3, -10.0), (2 * width / 3, -10.0), (width, 0.0)]
    for i in reversed(range(teeth)):
        x = i * pitch
        out += [(x + tooth, base), (x + tooth, base + length), (x, base + length), (x, base)]
    return out


WORST = {"circle": circle, "comb": comb, "gear": gear}


def fleet_field() -> None:
    print(
        f"{'1 km², 10 m':>12} {'mode':>12} {'waypoints':>9} {'plan ms':>8} {'split ms':>8}"
        f" {'total ms':>8} {'makespan s':>10}"
    )
    drones = team(10)
    for fly in (False, True):
        spec = field(1e6, fly, spacing_m=10.0)
        # Best of 5: the shared 2-core machine's noise (another job, a collection) only adds.
        plan_s, plan = timed(lambda s=spec: plan_area(s), repeat=5)
        split_s, shares = timed(lambda p=plan: split_route(p, drones, model=UNLIMITED), repeat=5)
        mode = "fly-through" if fly else "stop"
        print(
            f"{'10 drones':>12} {mode:>12} {len(plan.waypoints):>9} {plan_s * 1e3:>8.1f}"
            f" {split_s * 1e3:>8.1f} {(plan_s + split_s) * 1e3:>8.1f} {makespan_s(shares):>10.0f}"
        )


def worst_cases() -> None:
    print(
        f"{'2000-vertex':>12} {'angle °':>8} {'waypoints':>9} {'cells':>6} {'uncovered m²':>12}"
        f" {'plan ms':>8}"
    )
    for name, outline in WORST.items():
        spec = AreaSpec(polygon=latlon(outline()), spacing_m=10.0, action="takepic")
        plan_s, plan = timed(lambda s=spec: plan_area(s), repeat=1)
        print(
            f"{name:>12} {plan.angle_deg:>8.1f} {len(plan.waypoints):>9} {plan.cells:>6}"
            f" {plan.uncovered_m2:>12.3f} {plan_s * 1e3:>8.1f}"
        )


def sizes_and_splits() -> None:
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


def main() -> None:
    which = sys.argv[1] if len(sys.argv) > 1 else "all"
    if which in ("all", "fleet", "field"):
        fleet_field()
        print()
    if which in ("all", "fleet", "worst"):
        worst_cases()
        print()
    if which == "all":
        sizes_and_splits()


if __name__ == "__main__":
    main()
