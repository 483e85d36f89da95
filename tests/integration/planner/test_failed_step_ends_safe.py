"""A mission whose step fails in the air leaves its drone safe (issue 28, item 7).

Before, the drone hovered where the step failed (its mission ``failed``, nobody flying it): on
PX4 SITL a photo step without a camera, here any step. Now it flies the mission's end action
at once (drone/safe_end.py) and the failure says so. The camera is taken away after the mission
is accepted, as a camera that fails in flight would be.
"""

from __future__ import annotations

import math

import pytest

from dronefleet.experiments.harness import Harness
from dronefleet.geo.ned import lla_to_ned, ned_to_lla
from dronefleet.geo.types import NED
from dronefleet.ground.planner import launch
from dronefleet.ground.planner.models import MissionState
from dronefleet.ground.planner.options import MissionOptions

pytestmark = [pytest.mark.integration, pytest.mark.virtual_time]


@pytest.mark.parametrize("end_action", ["rtl", "land", "hold"])
async def test_a_failed_photo_step_flies_the_missions_end(end_action):
    options = MissionOptions(collaboration=False, replacement=False, end_action=end_action)
    async with Harness(speedup=20) as h:
        home = await h.add_drone("QUAD_A", NED(0, 0))
        await h.wait_identified(["QUAD_A"])
        await h.settle()
        there = ned_to_lla(NED(40, 0, 0), home)
        steps = [
            {"command": "navigate", "lat": there.lat, "lon": there.lon, "altitude_delta": 12},
            {"command": "wait_for_flight"},
            {"command": "takepic"},
            {"command": "navigate", "lat": home.lat, "lon": there.lon, "altitude_delta": 12},
            {"command": "wait_for_flight"},
        ]
        spec = launch.MissionSpec(name="fails", drones=["QUAD_A"], steps=steps, options=options)
        record = await launch.create(h.planner, spec, start=True)
        h.fleet.apps["QUAD_A"].gear.camera = None  # gone in flight
        record = await h.until_ended(record.mission_id, timeout_s=120)
        await h.settle(40.0)  # the end flown
        fc = h.fleet.apps["QUAD_A"].fc
        state = fc.state()
        offset = lla_to_ned(fc.position(), fc.home())

    assert record.state is MissionState.FAILED
    assert "has no camera" in (record.error or ""), record.error
    from_home = math.hypot(offset.n, offset.e)
    if end_action == "hold":
        assert "holding where it is" in record.error
        assert state.in_air and abs(from_home - 40) < 3 and -offset.d > 10, (state, offset)
    else:
        assert f"the mission's end: {end_action}" in record.error
        assert not state.in_air and not state.armed, state
        if end_action == "rtl":
            assert from_home < 3.0, offset
        else:
            assert abs(from_home - 40) < 3.0, offset
