"""On the footprint grid, stops that do something are made at cell centres; swath ends are passed.

The extended sensing area of the collaborative experiment (seed 5.4, twice 28 x 35 m at 7 m):
the path is the one the ends-included stops would give, every point of the area is as near a
stop, and each swath has one stop fewer.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from dronefleet.ground.planner.coverage import AreaSpec, Kind, plan_area

W, L = 28 * math.sqrt(2), 35 * math.sqrt(2)  # 39.6 x 49.5 m


def sensing(rect, **fields) -> AreaSpec:
    base = {"polygon": rect(W, L), "spacing_m": 7, "angle_deg": 0, "action": "read_sensors"}
    return AreaSpec(**{**base, "hold_s": 2, **fields})


def stops(plan) -> np.ndarray:
    return np.array([p.xy for p in plan.points if p.kind is Kind.WORK])


def farthest_from_stops(plan) -> float:
    area = plan.local_polygon
    minx, miny, maxx, maxy = area.bounds
    xs, ys = np.meshgrid(np.linspace(minx, maxx, 120), np.linspace(miny, maxy, 150))
    grid = shapely.points(xs.ravel(), ys.ravel())
    inside = np.asarray(shapely.get_coordinates(grid[shapely.covers(area, grid)]))
    s = stops(plan)
    return float(np.min(np.hypot(*(inside[:, None, :] - s[None, :, :]).T), axis=0).max())


def test_stops_are_cell_centres_and_the_swath_ends_are_passed(rect):
    plan = plan_area(sensing(rect))
    assert len(plan.swaths) == 6  # ceil(39.6 / 7)
    assert len(stops(plan)) == 6 * 8  # ceil(49.5 / 7) cells a swath, was 9 stops
    kinds = [p.kind for p in plan.points]
    assert kinds.count(Kind.TRANSIT) == 2 * 6 and kinds[0] is kinds[-1] is Kind.TRANSIT
    steps = plan.mission_steps()
    assert sum(s["command"] == "read_sensors" for s in steps) == 48
    assert plan.uncovered_m2 == 0


def test_the_path_and_the_nearness_of_a_stop_are_those_of_the_ends_included_grid(rect):
    centres = plan_area(sensing(rect))
    ends = plan_area(sensing(rect, action="none"))  # no action: stops at both ends, as before
    assert len([p for p in ends.points if p.kind is Kind.WORK]) == 6 * 9
    assert centres.local_path.hausdorff_distance(ends.local_path) < 1e-6
    cell = (W / 6, L / 8)
    half_diagonal = math.hypot(*cell) / 2
    assert farthest_from_stops(centres) == pytest.approx(half_diagonal, abs=0.15)
    assert farthest_from_stops(ends) == pytest.approx(half_diagonal, abs=0.15)


def test_the_seed_grid_keeps_its_stops_on_the_edges(rect):
    plan = plan_area(sensing(rect, polygon=rect(28, 35), grid="seed"))
    assert len(plan.points) == 30 and all(p.kind is Kind.WORK for p in plan.points)
