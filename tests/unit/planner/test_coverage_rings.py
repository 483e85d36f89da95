"""Rings (issue 30): a small area flown along its outline inward, where that is clearly quicker
than swaths; swaths everywhere else, and whenever the operator fixes the angle or asks for the
seed's grid. Figures are bench/coverage_vs_f2c.py's (the dog-leg: 836 / 840 m in swaths, 713 m
in rings, both at 100 %)."""

from __future__ import annotations

import math

import pytest
import shapely
from shapely.geometry import Polygon

from dronefleet.ground.planner.coverage import CoveragePipeline, plan_area
from dronefleet.ground.planner.coverage.contour import pointed, rings
from dronefleet.ground.planner.coverage.spec import Grid
from support.f2c_fields import coverage_pct, legs_of, spec

DOG_LEG = "thin dog-leg, 16 m wide"


@pytest.mark.parametrize("fly", [False, True], ids=["stop", "fly-through"])
def test_a_thin_dog_leg_is_flown_in_rings_a_seventh_shorter_than_its_swaths(fly):
    ringed = CoveragePipeline(headlands=False).plan(spec(DOG_LEG, fly=fly))
    swaths = CoveragePipeline(contours=False, headlands=False).plan(spec(DOG_LEG, fly=fly))
    assert (ringed.pattern, swaths.pattern) == ("rings", "swaths")
    assert ringed.path_length_m < 0.9 * swaths.path_length_m
    # With the headland offered too (the default), the route chosen is no longer.
    assert plan_area(spec(DOG_LEG, fly=fly)).path_length_m <= ringed.path_length_m + 1e-6
    assert coverage_pct(ringed) > 99.99
    assert ringed.uncovered_m2 == 0.0
    # Every leg inside the field, and the preview has no sweep angle to show.
    assert ringed.local_polygon.buffer(1e-6).covers(shapely.union_all(legs_of(ringed)))
    summary = ringed.summary()
    assert summary["angle_deg"] is None and summary["pattern"] == "rings"
    assert summary["swaths"] == len(ringed.swaths) > 0  # a ring's sides


def test_a_fixed_angle_or_the_seeds_grid_is_flown_in_swaths():
    assert plan_area(spec(DOG_LEG, angle_deg=30.0)).pattern == "swaths"
    assert plan_area(spec(DOG_LEG, grid=Grid.SEED)).pattern == "swaths"


@pytest.mark.parametrize("name", ["five-pointed star", "L-shaped", "400 x 12 m strip"])
def test_fields_whose_rings_are_not_clearly_quicker_keep_their_swaths(name):
    """The star's rings need spurs into every tip and leave its middle: 500 m or more against
    its swaths' 513 m, not 3 % quicker. (Its headland, one ring and swaths inside, is shorter:
    tests/unit/planner/test_coverage_headland.py; left out here.)"""
    plan = CoveragePipeline(headlands=False).plan(spec(name))
    assert plan.pattern == "swaths"
    assert plan.summary()["angle_deg"] is not None


def test_a_rings_corner_is_moved_to_within_half_a_spacing_of_the_fields_corner():
    square = Polygon([(0, 0), (100, 0), (100, 60), (0, 60)])
    (depth, first), *inner = rings(square, 10.0)
    assert depth == 0 and len(first) == 4
    assert all(k >= 1 for k, _ in inner)
    assert min(math.dist(c, (0.0, 0.0)) for c in first) == pytest.approx(math.sqrt(50))
    moved = pointed(first, 5.0, square.buffer(1e-6))
    for corner in [(0, 0), (100, 0), (100, 60), (0, 60)]:
        assert min(math.dist(c, corner) for c in moved) == pytest.approx(5.0)


def test_a_corner_whose_sides_would_leave_the_field_stays():
    # A kite whose sharp corners sit beside a reflex one: moved freely, a ring's corner's new
    # sides would cut across the field's edge (found among random outlines).
    field = Polygon([(16, 21), (-30, 24), (5, -52), (9, -57), (24, -35)])
    cover = field.buffer(1e-6)
    free = [pointed(r, 5.0, field.buffer(1000)) for _, r in rings(field, 10.0)]
    assert not all(cover.covers(shapely.LineString([*m, m[0]])) for m in free)
    for _, ring in rings(field, 10.0):
        moved = pointed(ring, 5.0, cover)
        assert cover.covers(shapely.LineString([*moved, moved[0]]))
