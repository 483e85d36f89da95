"""Every mission ends with a safe action (issue 14): a drone done with its share goes home.

Before, a drone that had flown its share hovered where its last waypoint was until its battery
gave out. Now each share ends with the mission's end action: home and land by default, land
where the work ended, or hold there.
"""

from __future__ import annotations

import math

import pytest

from dronefleet.experiments.harness import Harness
from dronefleet.geo.ned import lla_to_ned
from dronefleet.geo.types import NED
from dronefleet.ground.planner import launch
from dronefleet.ground.planner.models import MissionState
from dronefleet.ground.planner.options import MissionOptions
from support.missions import fly_early_handover, small_field_steps

pytestmark = [pytest.mark.integration, pytest.mark.virtual_time]


@pytest.mark.parametrize("end_action", ["rtl", "land", "hold"])
async def test_a_drone_done_with_its_share_does_the_missions_end_action(end_action):
    options = MissionOptions(
        collaboration=False, early_replacement=False, replacement=False, end_action=end_action
    )
    async with Harness(speedup=20) as h:
        await h.add_drone("QUAD_A", NED(0, 0))
        await h.wait_identified(["QUAD_A"])
        await h.settle()
        spec = launch.MissionSpec(name="ends", drones=["QUAD_A"], steps=small_field_steps(),
                                  options=options)  # fmt: skip
        record = await launch.create(h.planner, spec, start=True)
        record = await h.until_ended(record.mission_id, timeout_s=240)
        await h.settle(15.0)  # after the last report: the vehicle settles (and disarms)
        fc = h.fleet.apps["QUAD_A"].fc
        state, home = fc.state(), fc.home()
        offset = lla_to_ned(fc.position(), home)

    assert record.state is MissionState.COMPLETED, record.error
    leg = record.legs[0]
    assert [s["command"] for s in leg.suffix] == {
        "rtl": ["rtl", "wait_for_flight"],
        "land": ["land", "wait_for_flight"],
        "hold": [],
    }[end_action]
    from_home = math.hypot(offset.n, offset.e)
    if end_action == "rtl":
        assert not state.in_air and not state.armed and from_home < 3.0, (state, offset)
    elif end_action == "land":
        assert not state.in_air and not state.armed and from_home > 10.0, (state, offset)
    else:
        assert state.in_air and -offset.d > 5.0, (state, offset)


async def test_a_drone_handed_over_early_goes_home_and_so_does_its_replacement():
    """Issue 14: the departing drone of a replacement landed in the field (~140 m from home)."""
    async with Harness(speedup=20) as h:
        options = MissionOptions(collaboration=False)  # early replacement on, home at the end
        record = await fly_early_handover(h, options)
        landed = {}
        for drone_id in ("QUAD_A", "QUAD_B"):
            fc = h.fleet.apps[drone_id].fc
            offset = lla_to_ned(fc.position(), fc.home())
            landed[drone_id] = (fc.state().in_air, math.hypot(offset.n, offset.e))

    assert record.state is MissionState.COMPLETED, record.error
    handover = record.handovers[0]
    assert handover.kind == "early"
    leaving = record.leg(handover.leaving_leg)
    taking = record.leg(handover.to_leg)
    assert leaving is not None and taking is not None
    assert [s["command"] for s in leaving.suffix] == ["rtl", "wait_for_flight"]
    # Its way home may fly on a layer above the RTL height (ground/planner/deconflict/),
    # the other drone going home too: then a climb there first.
    commands = [s["command"] for s in taking.suffix]
    assert commands in (
        ["rtl", "wait_for_flight"],
        ["navigate", "wait_for_flight", "rtl", "wait_for_flight"],
    ), commands
    if len(commands) == 4:
        assert taking.suffix[0]["altitude_delta"] > 15.0
    for drone_id, (in_air, from_home) in landed.items():
        assert not in_air and from_home < 3.0, (drone_id, in_air, from_home)


@pytest.mark.parametrize("end_action", ["rtl", "land"])
async def test_a_drone_replaced_on_its_alarm_goes_home_unless_the_mission_lands_there(end_action):
    """Issue 14: a drone replaced after its CRITICAL alarm landed in the field. With the mission
    ending RTL (the default) it now goes home; a mission that ends by landing where it is keeps
    the seed's land-here (as the experiments do)."""
    steps = small_field_steps(alarm="CRITICAL")  # at the 13th waypoint
    options = MissionOptions(collaboration=False, early_replacement=False, end_action=end_action)
    async with Harness(speedup=20) as h:
        await h.add_drone("QUAD_A", NED(0, 0))
        await h.add_drone("QUAD_B", NED(-20, 0))
        await h.wait_identified(["QUAD_A", "QUAD_B"])
        await h.settle()
        spec = launch.MissionSpec(name="alarm", drones=["QUAD_A"], steps=steps, options=options)
        record = await launch.create(h.planner, spec, start=True)
        record = await h.until_ended(record.mission_id, timeout_s=300)
        await h.settle(30.0)
        fc = h.fleet.apps["QUAD_A"].fc
        offset = lla_to_ned(fc.position(), fc.home())
        in_air = fc.state().in_air

    assert record.state is MissionState.COMPLETED, record.error
    (handover,) = record.handovers
    assert handover.from_drone == "QUAD_A" and handover.to_drone == "QUAD_B"
    recovery = next(leg for leg in record.legs if leg.role == "recovery")
    from_home = math.hypot(offset.n, offset.e)
    assert not in_air
    if end_action == "rtl":
        assert [s["command"] for s in recovery.prefix] == ["rtl", "wait_for_flight"]
        assert from_home < 3.0, offset
    else:
        assert [s["command"] for s in recovery.prefix] == ["land", "wait_for_flight"]
        assert from_home > 10.0, offset
