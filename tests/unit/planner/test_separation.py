"""Predicted separation at acceptance (ground/planner/trajectory.py, separation.py,
deconflict/): crossing paths are caught, parallel swaths 8 m apart are fine, drones taking
off side by side are handled, and every deconflicted plan re-checks clean."""

from __future__ import annotations

import pytest

from dronefleet.drone.navigation import RTL_ALT_M as DRONE_RTL_ALT_M
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.ground.planner.deconflict import (
    LAYERS_M,
    MAX_DELAY_S,
    Share,
    separate,
    traffic_paths,
)
from dronefleet.ground.planner.estimate import estimate
from dronefleet.ground.planner.separation import (
    HORIZONTAL_M,
    VERTICAL_M,
    SeparationConflict,
    closest_approach,
    conflicts,
    first_conflict,
)
from dronefleet.ground.planner.trajectory import RTL_ALT_M, SAMPLE_S, predict

ORIGIN = LLA(40.63, -8.659, 10.0)


def at(n: float, e: float) -> LLA:
    return ned_to_lla(NED(n, e, 0.0), ORIGIN)


def go(n: float, e: float, up: float = 10.0) -> dict:
    p = at(n, e)
    return {"command": "navigate", "lat": p.lat, "lon": p.lon, "altitude_delta": up}


WAIT = {"command": "wait_for_flight"}
UP = [{"command": "arm"}, {"command": "takeoff", "value": 10.0}]


def share(drone: str, home: tuple[float, float], work: list[dict], **kw) -> Share:
    where = at(*home)
    return Share(drone, kw.pop("prefix", UP), work, kw.pop("end", []), where, where, False, **kw)


def hovering(drone: str, n: float, e: float, work: list[dict], up: float = 10.0) -> Share:
    where = ned_to_lla(NED(n, e, -up), ORIGIN)
    return Share(drone, [], work, [], where, at(n, e), True)


def paths(*shares: Share) -> list:
    return traffic_paths(list(shares), ORIGIN)


def steps_of(s: Share, placed) -> list[dict]:
    return [*placed.prefix, *s.work, *placed.end]


def recheck(shares: list[Share], placed) -> None:
    """The deconflicted plan, predicted again from the steps that will be sent, is clean."""
    sent = [
        Share(s.drone_id, p.prefix, s.work, p.end, s.start, s.home, s.airborne)
        for s, p in zip(shares, placed, strict=True)
    ]
    assert conflicts(paths(*sent), origin=ORIGIN) == []


def test_the_predicted_path_takes_as_long_as_the_estimate_and_flies_home_on_rtl() -> None:
    steps = [*UP, go(100, 0), WAIT, {"command": "rtl"}, WAIT]
    path = predict("A", steps, start=ORIGIN, home=ORIGIN, airborne=False, origin=ORIGIN)
    work_s = estimate(steps[:4], start=ORIGIN, home=ORIGIN, airborne=False).duration_s
    k = round(work_s / SAMPLE_S)
    assert path.n_m[k] == pytest.approx(98.0, abs=1.0)  # inside Algorithm 1's 2 m
    assert path.up_m.max() == pytest.approx(RTL_ALT_M, abs=0.05)  # home at RTL height
    assert path.n_m[-1] == pytest.approx(0.0, abs=2.0) and path.up_m[-1] == 0.0
    assert not path.in_air[-1] and not path.in_air[0]
    assert RTL_ALT_M == DRONE_RTL_ALT_M  # the drone's own RTL height


def test_crossing_paths_at_the_same_height_are_caught_where_they_cross() -> None:
    # Both hover 50 m from the crossing point and fly through it at the same moment.
    a = hovering("A", -50, 0, [go(50, 0), WAIT])
    b = hovering("B", 0, -50, [go(0, 50), WAIT])
    hit = first_conflict(*paths(a, b), origin=ORIGIN)
    assert hit is not None
    assert {hit.drone_a, hit.drone_b} == {"A", "B"}
    assert hit.horizontal_m < HORIZONTAL_M + 1e-6 and hit.vertical_m < VERTICAL_M
    assert 4.0 < hit.t_s < 8.0  # 50 m at up to 10 m/s
    crossing = at(0, 0)
    assert hit.position.lat == pytest.approx(crossing.lat, abs=5e-5)
    assert hit.position.lon == pytest.approx(crossing.lon, abs=5e-5)
    assert hit.position.alt_m == pytest.approx(ORIGIN.alt_m + 10.0, abs=0.5)


def test_a_crossing_between_two_samples_is_still_caught() -> None:
    # Head-on at 20 m/s closing speed: 10 m per sample, twice the 5 m minimum.
    a = hovering("A", 0, -100, [go(0, 100), WAIT])
    b = hovering("B", 0.0, 100, [go(0, -100), WAIT])
    pa, pb = paths(a, b)
    assert first_conflict(pa, pb, origin=ORIGIN) is not None


def test_the_same_crossing_3_m_apart_in_height_is_fine_and_2_m_is_not() -> None:
    a = hovering("A", -50, 0, [go(50, 0), WAIT])
    for up, clear in ((13.5, True), (12.0, False)):
        b = hovering("B", 0, -50, [go(0, 50, up), WAIT], up=up)
        hit = first_conflict(*paths(a, b), origin=ORIGIN)
        assert (hit is None) is clear, (up, hit)


def test_parallel_swaths_8_m_apart_are_fine() -> None:
    # Two drones flying neighbouring swaths side by side, 8 m apart, same height, same time,
    # there and back (a photo stop at the far end).
    stop = [WAIT, {"command": "sleep", "value": 3.0}]
    a = hovering("A", 0, 0, [go(60, 0), *stop, go(0, 0), WAIT])
    b = hovering("B", 0, 8, [go(60, 8), *stop, go(0, 8), WAIT])
    pa, pb = paths(a, b)
    assert first_conflict(pa, pb, origin=ORIGIN) is None
    flat, _ = closest_approach(pa, pb)
    assert 7.5 < flat < 8.5
    assert separate([a, b], []) and all(not p.notes for p in separate([a, b], []))


def test_drones_parked_3_m_apart_are_not_traffic_but_taking_off_together_is_handled() -> None:
    # Homes 3 m apart; both climb to 10 m and fly north to work 10 m apart.
    a = share("A", (0, 0), [go(40, 0), WAIT])
    b = share("B", (0, 3), [go(40, 10), WAIT])
    pa, pb = paths(a, b)
    hit = first_conflict(pa, pb, origin=ORIGIN)
    assert hit is not None and hit.t_s == pytest.approx(3.0, abs=0.6)  # at lift-off
    parked = Share("B", [], [], [], at(0, 3), at(0, 3), False)
    assert first_conflict(pa, paths(parked)[0], origin=ORIGIN) is None
    placed = separate([a, b], [])
    assert placed[0].delay_s == 0 and placed[0].layer_m == 0  # the first goes as planned
    assert placed[1].delay_s > 0 or placed[1].layer_m > 0
    assert "separation:" in placed[1].notes[0] and "A" in placed[1].notes[0]
    recheck([a, b], placed)


def test_a_crossing_is_deconflicted_against_traffic_and_the_result_rechecks_clean() -> None:
    # T is already on its way across; N, taking off 90 m west, would meet it at the crossing.
    flying = hovering("T", -120, 0, [go(120, 0), WAIT])
    new = share("N", (0, -90), [go(0, 90), WAIT])
    hit = first_conflict(*paths(new, flying), origin=ORIGIN)
    assert hit is not None
    (placed,) = separate([new], [flying])
    assert placed.layer_m in LAYERS_M and (placed.delay_s or placed.layer_m)
    sent = Share("N", placed.prefix, new.work, placed.end, new.start, new.home, False)
    assert first_conflict(*paths(sent, flying), origin=ORIGIN) is None


def test_transit_layers_raise_the_climb_and_the_way_home_never_the_work() -> None:
    from dronefleet.ground.planner.deconflict import layered

    work = [go(30, 0), WAIT, {"command": "takepic"}, go(30, 20), WAIT]
    s = share("A", (0, 0), work, end=[{"command": "rtl"}, WAIT])
    layer = layered(s, 8.0)
    assert layer is not None
    prefix, end = layer
    assert prefix[1] == {"command": "takeoff", "value": 18.0}
    assert prefix[2]["altitude_delta"] == 18.0 and prefix[2]["lat"] == work[0]["lat"]
    assert end[0]["altitude_delta"] == RTL_ALT_M + 8.0 and end[-2:] == s.end
    # A step list that takes off by itself is not ours to raise.
    own = Share("A", [], [*UP, *work], [], at(0, 0), at(0, 0), False)
    assert layered(own, 4.0) is None


def test_a_plan_that_cannot_be_separated_is_refused_naming_both_drones_the_time_and_place() -> None:
    # A drone hovering for good right on the only work point of another: no layer or delay helps.
    parked_in_the_air = hovering("T", 30, 0, [])
    new = share("N", (0, 0), [go(30, 0), WAIT, {"command": "sleep", "value": 5}])
    with pytest.raises(SeparationConflict) as caught:
        separate([new], [parked_in_the_air], ceiling_m=120)
    message = str(caught.value)
    assert "drones N and T" in message
    assert " s after the start, at 40.6" in message
    assert f"{MAX_DELAY_S:g} s" in message
    assert caught.value.conflict.t_s > 3.0  # after its take-off


def test_layers_above_the_ceiling_are_not_tried() -> None:
    a = hovering("A", -120, 0, [go(120, 0), WAIT])
    b = share("B", (0, -90), [go(0, 90), WAIT])
    assert first_conflict(*paths(a, b), origin=ORIGIN) is not None
    (placed,) = separate([b], [a], ceiling_m=11.0)
    assert placed.layer_m == 0.0 and placed.delay_s > 0
    assert placed.prefix[0] == {"command": "sleep", "value": placed.delay_s}
