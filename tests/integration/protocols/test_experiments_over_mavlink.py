"""Issue 6, must-show 1: the seed's four experiments run unchanged over MAVLink.

Every vehicle is simulated behind a MAVLink UDP endpoint (ArduPilot Copter semantics) in one sim
world; the drone software talks to it through the MAVLink backend. The same waypoints are reached
as with the in-process backend.
"""

from __future__ import annotations

import pytest

from dronefleet.experiments.scenarios import run

pytestmark = [pytest.mark.integration, pytest.mark.virtual_time]


@pytest.mark.parametrize("name", ["panic", "survey", "replacement", "collab"])
async def test_experiment_reaches_every_waypoint_over_mavlink(name):
    result = await run(name, strategy="ours", speedup=10.0, fc="mavlink")
    assert result.waypoints_planned > 0
    assert result.waypoints_reached == result.waypoints_planned
    if name == "replacement":
        assert result.notes["waypoints per drone"]["QUAD_B"] > 0
    if name == "collab":
        assert result.notes["area_m2 after expansion"] == pytest.approx(28 * 35 * 2.0, rel=0.01)
