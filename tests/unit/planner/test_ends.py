"""Every mission ends with a safe action (issue 14): the end steps a share is given."""

from __future__ import annotations

import pytest

from dronefleet.ground.planner.ends import end_steps, ends_on_the_ground
from dronefleet.ground.planner.options import MissionOptions

NAV = {"command": "navigate", "lat": 40.63, "lon": -8.659, "altitude_delta": 10}
WAIT = {"command": "wait_for_flight"}


def test_a_share_goes_home_by_default():
    assert MissionOptions().end_action == "rtl"
    assert end_steps("rtl", [NAV, WAIT]) == [{"command": "rtl"}, WAIT]
    assert end_steps("land", [NAV, WAIT]) == [{"command": "land"}, WAIT]
    assert end_steps("hold", [NAV, WAIT]) == []


@pytest.mark.parametrize(
    "tail",
    [
        [{"command": "land"}],
        [{"command": "rtl"}, WAIT],
        [{"command": "land"}, WAIT, {"command": "disarm"}],
    ],
)
def test_steps_that_already_end_on_the_ground_are_left_as_they_are(tail):
    steps = [NAV, WAIT, *tail]
    assert ends_on_the_ground(steps)
    assert end_steps("rtl", steps) == []


def test_a_landing_followed_by_more_flying_is_not_an_end():
    steps = [{"command": "land"}, WAIT, {"command": "arm"}, {"command": "takeoff", "value": 5}]
    assert not ends_on_the_ground(steps)
    assert end_steps("rtl", steps)[0] == {"command": "rtl"}


def test_an_unknown_end_action_is_refused():
    with pytest.raises(ValueError):
        MissionOptions(end_action="crash")
