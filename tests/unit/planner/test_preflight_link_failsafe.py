"""The pre-flight link check looks at the autopilot's own link-loss failsafe (issue 26, item 3):
off, a vehicle whose drone software dies hovers until its battery is flat, so it fails (an
operator may override it with a reason); on, it says what the autopilot would do; a drone on a
backend without one (the in-process simulator) is judged on its heartbeats alone."""

from __future__ import annotations

import pytest

from dronefleet.ground.planner import preflight
from dronefleet.messaging.status import LinkFailsafe

ONLINE = {"drone_id": "Q", "status": "online", "seen_ago_s": 1.0, "heartbeat_interval_s": 5.0}


@pytest.mark.parametrize(
    ("failsafe", "status", "words"),
    [
        ({"action": "off"}, "fail", "its autopilot's own link-loss failsafe is off"),
        ({"action": "rtl", "timeout_s": 5.0, "set_by_drone": True}, "pass", "rtl after 5 s"),
        ({"action": "land", "timeout_s": 10}, "pass", "autopilot failsafe: land after 10 s"),
        ({"action": "unknown"}, "pass", "one every 5.0 s"),
        (None, "pass", "one every 5.0 s"),
    ],
)
def test_link_check_reads_the_autopilots_failsafe(failsafe, status, words):
    got = preflight.link({**ONLINE, "link_failsafe": failsafe})
    assert got.status == status and words in got.reason, got


def test_the_heartbeats_model_of_it():
    said = LinkFailsafe(action="rtl", timeout_s=5.0, set_by_drone=True)
    assert said.model_dump() == {"action": "rtl", "timeout_s": 5.0, "set_by_drone": True}
    with pytest.raises(ValueError):
        LinkFailsafe(action="")
