"""What the coverage pipeline leaves undone because it cannot change the route (issue 30's
planning time): angles that cannot be closed are not guessed, an angle that can no longer be
chosen is not closed (or stops being closed), and the detours measure what they measured once.
The routes are the ones planned before (bench/coverage_vs_f2c.py's lengths).
"""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from dronefleet.ground.planner.coverage import CoveragePipeline
from dronefleet.ground.planner.coverage.candidate import (
    SAME_TIME,
    beaten,
    quicker,
    quicker_live,
)
from dronefleet.ground.planner.coverage.detours import Detours
from dronefleet.ground.planner.coverage.path import Kind, RoutePoint
from dronefleet.ground.planner.coverage.uncovered import Gap, find_gaps, outline
from support.f2c_fields import spec


class Counting(CoveragePipeline):
    """The default pipeline, counting the angles it guesses and closes (the rings it offers
    small areas besides are no angle: not counted)."""

    def __init__(self) -> None:
        super().__init__()
        object.__setattr__(self, "guessed", [])
        object.__setattr__(self, "closed", [])
        object.__setattr__(self, "left", [])  # gaps each closed angle left open

    def _guess(self, c, filler):  # type: ignore[no-untyped-def]
        self.guessed.append(c.angle)
        super()._guess(c, filler)

    def close_gaps(self, c, filler, over=None):  # type: ignore[no-untyped-def]
        super().close_gaps(c, filler, over)
        if c.pattern == "swaths":
            self.closed.append(c.angle)
            self.left.append(len(c.left))


def test_a_route_that_only_grows_is_beaten_once_slower_or_no_shorter_than_one_that_stays_near():
    assert not beaten(100.0, 500.0, [])
    # Past SAME_TIME of the quickest closed route: beaten, however short.
    assert beaten(100.0 * (1 + SAME_TIME) + 0.01, 10.0, [(100.0, 500.0)])
    # Within it, a closed route that stays near whatever this one ends at, no longer: beaten
    # (the shortest is flown, the first of equals).
    assert beaten(99.0, 500.0, [(100.0, 500.0)])
    assert beaten(99.0, 520.0, [(100.0, 500.0)])
    assert not beaten(99.0, 499.0, [(100.0, 500.0)])
    # Over 3 % quicker, it drops the closed one from the near ones: it may still win longer.
    assert not beaten(96.0, 520.0, [(100.0, 500.0)])


def test_a_route_stopped_part_way_is_no_rival_to_a_finished_one():
    timed = [(100.0, 400.0), (101.0, 450.0)]
    assert quicker(timed) == 0
    assert quicker_live(timed, [False, True]) == 1
    assert quicker_live(timed, [True, True]) == quicker_live(timed, [False, False]) == 0


@pytest.mark.parametrize("fly", [False, True], ids=["stop", "fly-through"])
def test_the_ponds_second_angle_is_not_closed_it_began_longer_than_the_first_ended(fly):
    """Its route before any gap (1570 m) was longer than the first angle's closed (1546, 1559
    m) and within 3 % of its time: it could not be flown, and closing it was 20 ms."""
    pipeline = Counting()
    plan = pipeline.plan(spec("field with a pond", fly=fly))
    assert len(pipeline.closed) == 1
    assert plan.path_length_m == pytest.approx(1558.5 if fly else 1546.4, abs=0.1)


def test_the_traced_outlines_second_angle_stops_once_it_cannot_be_flown():
    """It began 117 m shorter than the first angle ended (2951 m) and caught up midway: it stops
    there with gaps open, and the first is flown, all covered."""
    pipeline = Counting()
    plan = pipeline.plan(spec("traced outline, 240 vertices"))
    first, second = pipeline.left
    assert first == 0 < second
    assert plan.path_length_m == pytest.approx(2951.0, abs=0.1)
    assert plan.uncovered_m2 == 0.0


def test_an_angle_slower_than_two_guesses_before_its_gaps_is_not_guessed():
    """The U's third angle (271 s before its gaps) is slower than the two others' guesses (262
    and 259 s): a guess is never less, so it could not be closed; its gap search is not made."""
    pipeline = Counting()
    plan = pipeline.plan(spec("U-shaped"))
    assert len(pipeline.guessed) == 2
    assert plan.path_length_m == pytest.approx(2191.2, abs=0.1)


def test_a_gap_keeps_the_outline_it_was_measured_on_for_the_detours():
    """find_gaps samples each gap's outline every two tolerances; the detours measure the same
    samples (sampling again for each detour was a tenth of their time)."""
    square = shapely.box(0.0, 0.0, 40.0, 40.0)
    # Two passes across a 40 m square at 10 and 30 m: strips left at either side and between.
    points = [RoutePoint(*xy, Kind.TRANSIT) for xy in [(0, 10), (40, 10), (40, 30), (0, 30)]]
    gaps = find_gaps(points, square, 4.0, 0.02)
    assert gaps
    for g in gaps:
        assert g.outline is not None
        assert np.array_equal(g.outline, outline(g.shape, 0.04))
        assert np.array_equal(g.sampled(0.04), g.outline)
        bare = Gap(g.near, g.far, g.area_m2, g.shape)
        assert np.array_equal(bare.sampled(0.04), g.outline)


def test_each_legs_orphan_probes_are_found_once_per_gap(monkeypatch):
    """A detour of a leg must still reach the probes only that leg reached; those depend on the
    route alone, so each leg's are found once per gap, not once per detour tried."""
    asked: list[tuple[int, int]] = []
    found = Detours._orphans
    calls = {"n": 0}
    cheapest = Detours.cheapest

    def counting_cheapest(self, *args):  # type: ignore[no-untyped-def]
        calls["n"] += 1
        return cheapest(self, *args)

    def counting_orphans(self, xy, k, cover):  # type: ignore[no-untyped-def]
        asked.append((calls["n"], k))
        return found(self, xy, k, cover)

    monkeypatch.setattr(Detours, "cheapest", counting_cheapest)
    monkeypatch.setattr(Detours, "_orphans", counting_orphans)
    plan = CoveragePipeline(headlands=False).plan(spec("five-pointed star"))  # its swaths
    assert asked and len(asked) == len(set(asked))
    assert plan.path_length_m == pytest.approx(512.7, abs=0.1)


def test_a_routes_time_and_length_are_measured_together_as_apart():
    """The bound checked after every gap closed takes both from one pass over the route."""
    from dronefleet.ground.planner.coverage.candidate import route_length
    from dronefleet.ground.planner.coverage.cost import RouteTime

    rng = np.random.default_rng(30)
    timing = RouteTime()
    for n in (1, 2, 5, 60):
        xy = rng.uniform(0, 100, size=(n, 2)).tolist()
        kinds = list(Kind)
        points = [RoutePoint(x, y, kinds[k % len(kinds)]) for k, (x, y) in enumerate(xy)]
        points.insert(1, RoutePoint(*points[0].xy, Kind.WORK))  # a leg of no length
        assert timing.timed(points, 2.0) == (timing.of(points, 2.0), route_length(points))
