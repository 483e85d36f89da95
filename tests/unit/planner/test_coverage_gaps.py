"""Closing what the swaths leave uncovered (issue 30): bends, spikes and spurs.

A star's tips and an arrowhead's corners are closed by bending the legs beside them rather than by
spurs; a sliver beside a swath by a spike out and back; the gap filler stops once its route is
past its bound. The detours' numpy distances and reach checks answer as measuring with shapely,
or every sample, would.
"""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, Polygon

from dronefleet.ground.planner.coverage import CoveragePipeline, plan_area
from support.f2c_fields import SPACING, coverage_pct, legs_of, spec


@pytest.mark.parametrize("name", ["five-pointed star", "concave arrowhead"])
def test_gaps_are_closed_by_bending_the_route_for_less_than_spurs(name):
    """A star's tips and an arrowhead's corners: the legs beside a gap bend through it (a
    transit under a tip flies up into it and down again) instead of a spur out and back, at
    the same 100 % and with every leg still inside the field."""
    bent = plan_area(spec(name))
    spurs = CoveragePipeline(detours=False).plan(spec(name))
    assert bent.path_length_m < 0.97 * spurs.path_length_m
    assert coverage_pct(bent) >= 100.0 - 0.01
    area = bent.local_polygon
    assert shapely.covers(area.buffer(1e-3), legs_of(bent)).all(), "a leg leaves the field"


def test_distances_to_a_route_are_shapelys_and_a_bent_leg_loses_what_it_did_before():
    """The numpy distances the detours measure with (coordinates apart, legs far from a leg's
    probes skipped) are GEOS's, and skipping the far legs changes no answer of _loses."""
    from dronefleet.ground.planner.coverage.detours import (
        PROBE_ACROSS,
        PROBE_ALONG,
        Detours,
        _distances,
    )
    from dronefleet.ground.planner.coverage.path import PathBuilder

    rng = np.random.default_rng(30)
    route = np.cumsum(rng.uniform(-20, 20, size=(60, 2)), axis=0)
    points = rng.uniform(route.min(axis=0), route.max(axis=0), size=(200, 2))
    want = shapely.distance(shapely.points(points), LineString(route))
    assert np.allclose(_distances(points, route), want, atol=1e-9)
    detours = Detours(5.0, 0.02, PathBuilder(SPACING))
    cover = shapely.box(*route.min(axis=0), *route.max(axis=0)).buffer(10.0)
    counted: list[bool] = []
    for k in range(len(route) - 1):
        bent = np.array([route[k], route[k] + rng.uniform(-6, 6, 2), route[k + 1]])
        reach = detours.radius_m + detours.tolerance_m
        # What _loses decided without the filter: any probe only leg k reached, now unreached.
        lost = detours._loses(route, k, bent, cover)
        a, b = route[k], route[k + 1]
        d = b - a
        normal = np.array([-d[1], d[0]]) / float(np.hypot(*d))
        probes = (
            (a + np.outer(PROBE_ALONG, d))[:, None, :]
            + (np.outer(PROBE_ACROSS, normal) * reach)[None, :, :]
        ).reshape(-1, 2)
        probes = probes[shapely.contains_xy(cover, probes[:, 0], probes[:, 1])]
        probes = probes[_distances(probes, bent) > reach]
        others = np.stack([np.delete(route[:-1], k, 0), np.delete(route[1:], k, 0)], axis=1)
        brute = len(probes) > 0 and bool((_distances(probes, others) > reach).any())
        assert lost == brute
        counted.append(lost)
    assert 0 < sum(counted) < len(counted)  # both answers occur


def test_whether_a_gap_outline_is_beyond_reach_is_answered_as_measuring_every_sample():
    """_beyond measures one outline sample in 16 first, the rest only where they could be
    farther: the answer is the one measuring all gives, on either side of the limit."""
    from dronefleet.ground.planner.coverage.detours import _beyond, _distances

    rng = np.random.default_rng(11)
    outline = np.cumsum(rng.uniform(-0.04, 0.04, size=(3000, 2)), axis=0)
    for _ in range(50):
        corners = rng.uniform(outline.min(axis=0), outline.max(axis=0), size=(3, 2))
        far = float(_distances(outline, corners).max())
        for limit in (far - 1e-3, far + 1e-3, far * 0.5):
            assert _beyond(outline, corners, limit) == (far > limit)


def test_distances_to_many_detours_at_once_are_each_detours_own():
    """The detours tried for a gap are refused in one go (_distances_each): the same distances
    as measuring each detour's corners alone, a point's zero-length leg included."""
    from dronefleet.ground.planner.coverage.detours import _distances, _distances_each

    rng = np.random.default_rng(7)
    points = rng.uniform(-30, 30, size=(40, 2))
    polylines = rng.uniform(-30, 30, size=(12, 4, 2))
    polylines[::3, 2] = polylines[::3, 1]  # s0 == s1: a detour through a point
    each = _distances_each(points, polylines)
    for m, corners in enumerate(polylines):
        assert np.allclose(each[m], _distances(points, corners), atol=1e-12)


@pytest.mark.parametrize("fly", [False, True], ids=["stop", "fly-through"])
def test_a_sliver_beside_a_swath_is_closed_by_a_spike_that_keeps_the_swath(fly):
    """A 1.5 m bump beside the middle of a 40 m swath (a reflex corner's sliver): no bend of
    the swath reaches it without uncovering the far side of its strip, and a spur from its
    ends flies 40 m. A spike from the swath's nearest point, out and back, closes it for
    under 4 m; a fly-through swath's camera run stops at the spike's foot and goes on."""
    from dronefleet.ground.planner.coverage.detours import Detours
    from dronefleet.ground.planner.coverage.path import Kind, PathBuilder
    from dronefleet.ground.planner.coverage.route import Stroke
    from dronefleet.ground.planner.coverage.uncovered import find_gaps

    area = Polygon([(0, -5), (40, -5), (40, 5), (22, 5), (20, 6.5), (18, 5), (0, 5)])
    builder = PathBuilder(SPACING, fly_through=fly, trigger_m=8.0, photo_at_work=True)
    points = builder.along((0.0, 0.0), (40.0, 0.0))
    (gap,) = find_gaps(points, area, 5.0, 0.02)
    xy = np.array([p.xy for p in points])
    cover = area.buffer(1e-6)
    found = Detours(5.0, 0.02, builder).cheapest(points, xy, gap, Stroke(gap.near, gap.far), cover)
    assert found is not None
    k, leg = found
    flown = [*points[:k], *leg, *points[k + 2 :]]
    line = np.array([p.xy for p in flown])
    added = float(np.hypot(*np.diff(line, axis=0).T).sum()) - 40.0
    assert 0 < added < 4.0
    assert flown[0].xy == (0.0, 0.0) and flown[-1].xy == (40.0, 0.0)
    assert not find_gaps(flown, area, 5.0, 0.02)
    tip = max(flown, key=lambda p: p.y)
    assert tip.kind is Kind.WORK and 1.0 < tip.y < 2.0 and 19.0 < tip.x < 21.0
    if fly:  # two camera runs, each started and ended
        kinds = [p.kind for p in flown]
        assert kinds.count(Kind.SWATH_START) == kinds.count(Kind.SWATH_END) == 2


def test_the_filler_stops_once_the_route_is_past_its_bound_and_says_what_is_left():
    """A second angle's gaps are closed only while it can still beat the first's route
    (closing only adds to a route): told that every route is over, the filler closes the
    largest gap and returns the others as left; told nothing, it closes them all."""
    from dronefleet.ground.planner.coverage.gaps import GapFiller
    from dronefleet.ground.planner.coverage.path import PathBuilder
    from dronefleet.ground.planner.coverage.router import InAreaRouter

    bumps = [(30, 5), (28, 8), (26, 5), (22, 5), (20, 6.5), (18, 5)]
    area = Polygon([(0, -5), (40, -5), (40, 5), *bumps, (0, 5)])
    builder = PathBuilder(SPACING)
    points = builder.along((0.0, 0.0), (40.0, 0.0))
    filler = GapFiller(5.0, 0.02, builder)
    router = InAreaRouter(area)
    assert len(filler.gaps(points, area)) == 2
    done, left = filler.fill(points, area, router)
    assert left == [] and not filler.gaps(done, area)
    part, left = filler.fill(points, area, router, over=lambda p: True)
    assert len(left) == 1 and 2.0 < left[0].area < 3.0  # the smaller bump's gap
    assert len(filler.gaps(part, area)) == 1
