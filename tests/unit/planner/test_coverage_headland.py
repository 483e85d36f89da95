"""Headland routes (issue 30): a small area's outline flown once, half a spacing inside, then
swaths over what that leaves, where that is chosen over the swaths (quicker within 3 %, and
shorter). Figures are bench/coverage_vs_f2c.py's: the five-pointed star at 100 % flew 513 m
(stop) and 516 m (fly-through) in swaths, against a goal of 492.7 m (Fields2Cover's 483 m, which
leaves 2.5 % uncovered, plus 2 %); by its headland, 484 m in both modes."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from shapely.geometry import Polygon

from dronefleet.ground.planner.coverage import AreaSpec, CoveragePipeline, plan_area
from dronefleet.ground.planner.coverage.headland import least_m, sides
from dronefleet.ground.planner.coverage.route import WholeFieldOrderer
from dronefleet.ground.planner.coverage.router import reflex_corners
from support.f2c_fields import FIELDS, SPACING, coverage_pct, legs_of, ring, spec

STAR = "five-pointed star"


def star(points: int, outer: float, inner: float, turn_deg: float) -> list[tuple[float, float]]:
    """A regular star's outline, (east, north) metres, its first tip ``turn_deg`` from north."""
    out = []
    for k in range(2 * points):
        r = outer if k % 2 == 0 else inner
        a = math.radians(turn_deg) + math.pi * k / points
        out.append((r * math.sin(a), r * math.cos(a)))
    return out


def area_spec(outline, holes=(), *, fly: bool = False) -> AreaSpec:
    return AreaSpec(
        polygon=ring(outline),
        holes=[ring(h) for h in holes],
        spacing_m=SPACING,
        action="takepic",
        fly_through=fly,
    )


@pytest.mark.parametrize("fly", [False, True], ids=["stop", "fly-through"])
def test_the_star_at_100_pct_is_flown_within_its_goal(fly):
    plan = plan_area(spec(STAR, fly=fly))
    f2c = FIELDS[STAR]["fields2cover"]  # the bench's goal: its path + 2 %, as it leaves 2.5 %
    goal = FIELDS[STAR].get("goal_at_100_pct_m", 1.02 * f2c["path_m"])
    assert f2c["coverage_pct"] < 100.0
    assert plan.path_length_m <= goal  # 492.7 m; 513 / 516 m in swaths
    assert coverage_pct(plan) >= 99.995  # the bench's 100.00
    assert plan.uncovered_m2 == 0.0
    assert plan.pattern == "headland"
    assert plan.summary()["angle_deg"] is None
    swaths = CoveragePipeline(headlands=False).plan(spec(STAR, fly=fly))
    assert swaths.pattern == "swaths" and swaths.path_length_m > goal


@pytest.mark.parametrize(
    ("outline", "holes"),
    [
        (star(6, 55.0, 28.0, 7.0), [[(-5, -5), (5, -5), (5, 5), (-5, 5)]]),
        (star(4, 45.0, 16.0, 10.0), []),
        (star(7, 60.0, 30.0, 0.0), []),
    ],
    ids=["six-pointed with a pond", "four-pointed, turned", "seven-pointed"],
)
@pytest.mark.parametrize("fly", [False, True], ids=["stop", "fly-through"])
def test_other_stars_are_covered_by_a_shorter_headland_inside_the_field(outline, holes, fly):
    plan = plan_area(area_spec(outline, holes, fly=fly))
    without = CoveragePipeline(headlands=False).plan(area_spec(outline, holes, fly=fly))
    assert plan.pattern == "headland"
    assert plan.path_length_m < 0.99 * without.path_length_m
    assert coverage_pct(plan) > 99.99
    assert plan.uncovered_m2 == 0.0
    # Every leg, transits included, inside the field and outside its pond.
    field = plan.local_polygon
    assert len(field.interiors) == len(holes)
    assert field.buffer(1e-6).covers(shapely.union_all(legs_of(plan)))


@pytest.mark.parametrize("name", ["L-shaped", "field with a pond", "concave arrowhead"])
def test_fields_whose_headland_is_longer_keep_their_swaths(name):
    plan = plan_area(spec(name))
    assert plan.pattern == "swaths"
    assert plan.path_length_m == CoveragePipeline(headlands=False).plan(spec(name)).path_length_m


def test_a_fixed_angle_is_flown_in_swaths():
    assert plan_area(spec(STAR, angle_deg=0.0)).pattern == "swaths"


def test_sides_are_half_a_spacing_in_with_pointed_tips_and_no_bevels():
    field = Polygon(star(5, 52.0, 20.0, 0.0))
    flown = sides(field, 10.0)
    assert len(flown) == 10  # two per tip; the five bevels at the reflex corners are not flown
    ends = np.array([e for s in flown for e in (s.start, s.end)])
    for x, y in reflex_corners(field):  # each side ends half a spacing from its reflex corner
        d = np.hypot(ends[:, 0] - x, ends[:, 1] - y)
        assert np.sum(np.isclose(d, 5.0, atol=0.05)) == 2
    for x, y in star(5, 52.0, 20.0, 0.0)[::2]:  # each tip flown to within half a spacing
        assert np.hypot(ends[:, 0] - x, ends[:, 1] - y).min() == pytest.approx(5.0, abs=0.01)
    outline = field.exterior
    for s in flown:  # each side half a spacing from the edge it follows, at its far end
        assert max(
            outline.distance(shapely.Point(s.start)), outline.distance(shapely.Point(s.end))
        ) == pytest.approx(5.0, abs=0.05)
        assert field.covers(shapely.LineString([s.start, s.end]))


def test_least_m_is_never_more_than_a_route_through_the_passes():
    field = Polygon(star(5, 52.0, 20.0, 0.0))
    flown = sides(field, 10.0)
    routed = WholeFieldOrderer().reorder(list(flown), [], (0.0, 52.0), field)
    xy = [p.start for p in routed.passes[:1]]
    for p in routed.passes:
        xy += [*routed.transits.path(xy[-1], p.start)[1:], p.end]
    assert least_m(flown) <= shapely.LineString(xy).length + 1e-6
    assert least_m(flown) >= sum(math.dist(s.start, s.end) for s in flown)
