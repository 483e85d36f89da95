"""Who flies a share, and a mission asked on board that cannot be (issue 28, item 3).

Before, a mission asked on board with a step the autopilot cannot fly was flown from the
companion computer without a word. Now the planner refuses it naming the step (422), and when
the operator did not insist it says on the share (preview and leg) why it will not be on board.
"""

from __future__ import annotations

import pytest

from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.ground.planner import launch
from dronefleet.ground.planner.fleet_view import DroneView
from dronefleet.ground.planner.options import MissionOptions
from dronefleet.ground.planner.service import PlannerError
from dronefleet.protocols.mavlink.items import onboard_refusal

HOME = LLA(40.63, -8.66, 10.0)
FLEET = {"QUAD_1": DroneView("QUAD_1", True, "disarmed", None, HOME, HOME, 100.0)}


def planned(steps: list[dict], **options) -> dict:
    spec = launch.MissionSpec(
        drones=["QUAD_1"], steps=steps, options=MissionOptions(collaboration=False, **options)
    )
    (share,) = launch.plan_mission(spec, FLEET, set(), 20.0, 120.0).shares
    return share[4]


def waypoint(n: float, e: float) -> list[dict]:
    p = ned_to_lla(NED(n, e), HOME)
    return [
        {"command": "navigate", "lat": p.lat, "lon": p.lon, "altitude_delta": 15},
        {"command": "wait_for_flight"},
    ]


def test_every_end_can_be_flown_on_board():
    for end in (["rtl", "wait_for_flight"], ["land", "wait_for_flight"], []):
        assert onboard_refusal(["arm", "takeoff", "navigate", "wait_for_flight", *end]) is None
    assert onboard_refusal(["arm", "takeoff", "changeN"]) == (
        2,
        "changeN has no on-board (MAVLink mission item) form",
    )
    assert onboard_refusal(["takeoff", "arm"])[0] == 1


@pytest.mark.parametrize("end_action", ["rtl", "land", "hold"])
def test_a_share_asked_on_board_says_the_autopilot_flies_it(end_action):
    share = planned(waypoint(50, 0), onboard=True, end_action=end_action)
    assert share["flown_by"] == "autopilot" and share["companion_reason"] is None


def test_a_share_asked_on_board_with_a_step_it_cannot_fly_there_is_refused_naming_the_step():
    steps = [*waypoint(50, 0), {"command": "changeN", "value": 10}, {"command": "wait_for_flight"}]
    with pytest.raises(PlannerError, match=r"on board.*step 2 \(changeN\): changeN has no"):
        planned(steps, onboard=True)


def test_without_insisting_the_share_says_why_it_flies_from_the_companion_computer():
    steps = [*waypoint(50, 0), {"command": "read_sensors", "value": 2}]
    share = planned(steps)
    assert share["flown_by"] == "companion"
    assert share["companion_reason"].startswith("step 2 (read_sensors): read_sensors has no")
    assert planned(waypoint(50, 0))["flown_by"] is None  # the drone's configuration decides
    asked = planned(waypoint(50, 0), onboard=False)
    assert asked["flown_by"] == "companion" and "asks" in asked["companion_reason"]
