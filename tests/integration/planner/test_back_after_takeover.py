"""A drone heard again after its work was taken over flies none of it again (issue 26), in one
process on virtual time.

QUAD_A's link is cut mid-share: lost after 3 s, QUAD_B takes over after 3 s more and starts on
the work. QUAD_A, not dead, flies on unheard (the drone's default on a lost link). When it is
heard again it is sent home, and the steps it reports having flown unheard are the replacement's
no more: QUAD_B is given only what neither has flown (before: QUAD_B flew all of them again).
What both flew while QUAD_A was unheard cannot be undone by the ground: a drone that must never
duplicate a step holds on a lost link (``dronefleet drone --link-loss hold``). Counted from the
drones' own reports (they keep every report they send).
"""

from __future__ import annotations

import pytest

from dronefleet.experiments.harness import Harness
from dronefleet.ground.planner.lost import TRIM_AFTER_S
from dronefleet.ground.planner.models import LegRole, MissionState

from .test_takeover_once import WAYPOINTS, cut, mend, start_and_fly, until

pytestmark = [pytest.mark.integration, pytest.mark.virtual_time]


def flown_by_drones(h: Harness, record) -> dict[int, dict[str, float]]:
    """Waypoint (wait_for_flight step) -> the drones that reported it, with the vehicle time of
    their report, from the drones' own kept reports."""
    seen: dict[int, dict[str, float]] = {}
    for leg in record.legs:
        kept = h.fleet.apps[leg.drone_id].mission_worker.reports.kept.get(leg.leg_id, [])
        for p in kept:
            if p.event.value != "step" or p.step_index is None:
                continue
            index = leg.global_index(p.step_index)
            if index is not None and record.work[index]["command"] == "wait_for_flight":
                seen.setdefault(index, {})[leg.drone_id] = p.vehicle_time_s
    return seen


async def test_a_drone_back_after_its_takeover_leaves_its_replacement_only_what_it_did_not_fly():
    async with Harness(speedup=10) as h:
        mission_id = await start_and_fly(h, done=6)
        await cut(h, "QUAD_A")
        record = h.planner.missions[mission_id]
        await until(lambda: any(x.committed for x in record.handovers), timeout_s=60)
        await h.clock.sleep(2.0)  # QUAD_B on the work; QUAD_A flies on unheard
        heard_at = h.clock.now()
        await mend(h, "QUAD_A")
        record = await h.until_ended(mission_id, timeout_s=240)
        await h.settle(10.0)
        flown = flown_by_drones(h, record)
    assert record.state is MissionState.COMPLETED, record.error
    twice = {i: who for i, who in flown.items() if len(who) > 1}
    print("flown twice:", twice, "QUAD_A heard again at", heard_at)
    assert [lg.drone_id for lg in record.legs if lg.role is LegRole.RECOVERY] == ["QUAD_A"]
    assert len(flown) == WAYPOINTS  # every waypoint flown
    # Only what QUAD_B reached while QUAD_A was still unheard; nothing after QUAD_A was back.
    # (Allowing its heartbeat, its burst of reports and the cut leg's way to QUAD_B.)
    late = {i: who for i, who in twice.items() if who["QUAD_B"] > heard_at + TRIM_AFTER_S + 2}
    assert not late, f"flown again after QUAD_A was heard: {late}"
    cut_legs = [
        lg for lg in record.legs if lg.drone_id == "QUAD_B" and lg.role is LegRole.REPLACEMENT
    ]
    assert len(cut_legs) == 2  # its leg cut once to what QUAD_A had not flown
