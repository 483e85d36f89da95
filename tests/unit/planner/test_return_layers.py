"""Return layers and landings in turn (issue 28, item 4): drones that go home together fly home
on layers of their own, and one whose home is near another's landing waits at its layer."""

from __future__ import annotations

import pytest

from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.ground.planner.deconflict import Share, separate, traffic_paths
from dronefleet.ground.planner.ends import layered_return, return_layers
from dronefleet.ground.planner.separation import conflicts

ORIGIN = LLA(40.63, -8.659, 10.0)


def at(n: float, e: float) -> LLA:
    return ned_to_lla(NED(n, e, 0.0), ORIGIN)


def going_home(drone: str, home: tuple[float, float], height: float, east: float = 0.0) -> Share:
    """Hovering 40 m north of its home (and ``east`` of it) at 10 m, done: its way home on
    ``height``."""
    where = ned_to_lla(NED(home[0] + 40, home[1] + east, -10), ORIGIN)
    last = (where.lat, where.lon)
    return Share(drone, [], [], layered_return(last, at(*home), height), where, at(*home), True)


def test_layers_are_4_m_apart_above_the_work_and_the_rtl_altitude():
    assert return_layers(3, max(10.0, 15.0)) == [20.0, 24.0, 28.0]
    steps = layered_return((40.6301, -8.659), at(0, 6), 24.0)
    assert [s["command"] for s in steps] == [
        "navigate", "wait_for_flight", "navigate", "wait_for_flight", "rtl", "wait_for_flight",
    ]  # fmt: skip
    assert steps[0]["altitude_delta"] == steps[2]["altitude_delta"] == 24.0


def test_a_drone_whose_home_is_near_another_landing_waits_at_its_layer_until_it_is_down():
    # Homes 3 m apart: on layers 20 and 24 m they cross fine, but the second would come down
    # through the first's height over almost the same spot.
    # A comes from farther away: B, higher, would be coming down as A arrives below it.
    a, b = going_home("A", (0, 0), 20.0, east=-80.0), going_home("B", (0, 3), 24.0)
    assert conflicts(traffic_paths([a, b], ORIGIN), origin=ORIGIN)  # as planned: too close
    first, second = separate([a, b], [])
    assert first.hold_s == 0.0
    assert second.hold_s > 0 and second.layer_m == 0.0 and second.delay_s == 0.0
    assert "lands after waiting" in second.notes[0]
    sleep = [s for s in second.end if s["command"] == "sleep"]
    assert sleep == [{"command": "sleep", "value": second.hold_s}]
    assert second.end[-2]["command"] == "rtl"  # it waits over home, then comes down
    sent = [
        Share(s.drone_id, p.prefix, s.work, p.end, s.start, s.home, s.airborne)
        for s, p in zip([a, b], [first, second], strict=True)
    ]
    assert conflicts(traffic_paths(sent, ORIGIN), origin=ORIGIN) == []


@pytest.mark.parametrize("apart_m", [6.0, 15.0])
def test_homes_5_m_or_more_apart_need_no_wait(apart_m):
    a, b = going_home("A", (0, 0), 20.0), going_home("B", (0, apart_m), 24.0, east=20.0)
    assert conflicts(traffic_paths([a, b], ORIGIN), origin=ORIGIN) == []
    assert [p.hold_s for p in separate([a, b], [])] == [0.0, 0.0]
