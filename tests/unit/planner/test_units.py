"""Resuming work: whole waypoint units, none skipped, none flown twice, alarms never re-sent."""

from hypothesis import given
from hypothesis import strategies as st

from dronefleet.ground.planner.units import remaining, units


def wp(n: int, action: str | None = "takepic") -> list[dict]:
    steps = [
        {"command": "navigate", "lat": 40 + n * 1e-4, "lon": -8.0},
        {"command": "wait_for_flight"},
    ]
    return steps + ([{"command": action}] if action else [])


def survey(n: int) -> list[dict]:
    return [s for i in range(n) for s in wp(i)]


def test_a_unit_is_a_movement_and_the_steps_after_it():
    work = [{"command": "camera_trigger", "value": 0}, *survey(3)]
    assert units(work) == [[0], [1, 2, 3], [4, 5, 6], [7, 8, 9]]


def test_resuming_after_a_half_done_waypoint_repeats_that_whole_waypoint():
    work = survey(4)
    done = {0, 1, 2, 3, 4}  # waypoint 2 reached (navigate+wait) but its photo not taken
    assert remaining(work, list(range(len(work))), done) == [3, 4, 5, 6, 7, 8, 9, 10, 11]


def test_alarm_steps_are_never_sent_again():
    work = [*survey(2), {"command": "virtualalarm", "level": "CRITICAL"}, *survey(1)]
    left = remaining(work, list(range(len(work))), {0, 1, 2})
    assert all(work[i]["command"] != "virtualalarm" for i in left)


@given(st.integers(1, 30), st.data())
def test_done_plus_remaining_covers_every_waypoint_exactly_once(n, data):
    work = survey(n)
    all_idx = list(range(len(work)))
    cut = data.draw(st.integers(0, len(work)))
    done = set(all_idx[:cut])  # a drone flies in order and stops anywhere
    left = remaining(work, all_idx, done)
    complete = {tuple(g) for g in units(work) if all(i in done for i in g)}
    resumed = {tuple(g) for g in units(work, left)}
    assert not complete & resumed  # none flown twice
    assert complete | resumed == {tuple(g) for g in units(work)}  # none skipped
