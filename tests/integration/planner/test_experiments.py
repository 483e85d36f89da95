"""The seed's four experiments run in the suite, through broker, ground and drone controllers.

Issue 4, must-show 1: every waypoint is reached; the replacement resumes at the first unflown
waypoint and none is flown twice; the collaborative area grows by the seed's rule (+50% per
joining drone). Figures are in vehicle seconds; the loose bounds here only catch regressions
(the targets are reported by ``dronefleet experiment``, not asserted).
"""

from __future__ import annotations

import pytest

from dronefleet.experiments import scenarios
from dronefleet.experiments.harness import Harness
from dronefleet.ground.planner.units import units

pytestmark = [pytest.mark.integration, pytest.mark.virtual_time]
SPEEDUP = 10.0


def waypoint_reports(record) -> dict[int, list[str]]:
    """Global index of each wait_for_flight -> the drones that reported it done."""
    seen: dict[int, list[str]] = {}
    for leg in record.legs:
        for r in leg.reports:
            if r.index is not None and record.work[r.index]["command"] == "wait_for_flight":
                seen.setdefault(r.index, []).append(leg.drone_id)
    return seen


@pytest.mark.parametrize("strategy", ["ours", "seed"])
async def test_panic_button_brings_the_nearest_drone_to_the_caller(strategy):
    async with Harness(speedup=SPEEDUP) as h:
        result = await scenarios.panic(h, strategy)
    assert result.waypoints_reached == result.waypoints_planned == 1
    assert result.stages["arming"] == pytest.approx(3.0, abs=0.3)
    assert 15.0 < result.total_s < 25.0  # the seed flew it in under 25 s


async def test_survey_photographs_the_whole_area_flying_through():
    async with Harness(speedup=SPEEDUP) as h:
        result = await scenarios.survey(h, "ours")
    assert result.waypoints_reached == result.waypoints_planned
    assert result.notes["pictures"] == 45  # the seed's 32 x 64 m at 8 m
    assert result.total_s < 331.0


@pytest.mark.parametrize("strategy", ["seed", "ours"])
async def test_replacement_resumes_at_the_first_unflown_waypoint(strategy):
    async with Harness(speedup=SPEEDUP) as h:
        result = await scenarios.replacement(h, strategy)
        record = h.planner.missions[result.mission_id]
    assert result.waypoints_reached == result.waypoints_planned == 28
    seen = waypoint_reports(record)
    assert all(len(drones) == 1 for drones in seen.values()), seen  # none flown twice
    handover = record.handovers[0]
    first = record.legs[0]
    done_by_first = {i for i, d in record.done.items() if d == first.drone_id}
    flown = [g for g in units(record.work) if all(i in done_by_first for i in g)]
    unflown = [
        g
        for g in units(record.work)
        if g not in flown and record.work[g[0]]["command"] == "navigate"
    ]
    assert handover.resume_index == unflown[0][0]
    assert {record.done[i] for i in seen} == {"QUAD_A", "QUAD_B"}
    if strategy == "ours":
        assert handover.kind == "early" and result.gap_s is not None and result.gap_s < 5.0


async def test_collaboration_grows_the_area_by_the_seed_rule_and_covers_it():
    async with Harness(speedup=SPEEDUP) as h:
        result = await scenarios.collab(h, "ours")
        record = h.planner.missions[result.mission_id]
    expansion = record.expansions[0]
    assert len(expansion.joined) == 2
    assert expansion.area_factor == pytest.approx(1.0 + 0.5 * 2)
    assert expansion.area_m2 == pytest.approx(28 * 35 * 2.0, rel=0.01)
    assert result.waypoints_reached == result.waypoints_planned
    assert set(expansion.assignments) == {"QUAD_A", "QUAD_B", "QUAD_C"}
