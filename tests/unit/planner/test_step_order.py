"""Step lists walked as a drone flies them: the first step out of order is named (issue 14)."""

from __future__ import annotations

import pytest

from dronefleet.ground.planner.step_order import StepOrderError, check_order

NAV = {"command": "navigate", "lat": 40.63, "lon": -8.659, "altitude_delta": 10}


def steps(*names: str) -> list[dict]:
    made = {"nav": NAV, "takeoff": {"command": "takeoff", "value": 10}}
    return [made.get(n, {"command": n}) for n in names]


def check(names: tuple[str, ...], *, airborne: bool = False, prefix: int = 0) -> None:
    listed = steps(*names)
    check_order(
        listed,
        airborne=airborne,
        armed=False,
        index_of=[None] * prefix + list(range(len(listed) - prefix)),
    )


@pytest.mark.parametrize(
    "names",
    [
        ("arm", "takeoff", "nav", "wait_for_flight", "takepic", "land", "wait_for_flight"),
        ("arm", "takeoff", "land", "arm", "takeoff", "nav", "rtl"),  # a second flight
        ("takepic", "arm", "takeoff", "land", "disarm"),  # a picture before flying: fine
        ("arm", "takeoff", "land", "wait_for_flight", "disarm", "sleep"),
    ],
)
def test_lists_a_drone_can_fly_in_order_pass(names):
    check(names)


def test_a_flying_drone_may_navigate_straight_away():
    check(("nav", "takepic", "land"), airborne=True)


@pytest.mark.parametrize(
    ("names", "index", "words"),
    [
        (("arm", "takeoff", "land", "nav"), 3, "after the land at step 2: take off again"),
        (("arm", "takeoff", "rtl", "read_sensors"), 3, "after the rtl at step 2"),
        (("arm", "takeoff", "land", "changeN"), 3, "after the land at step 2"),
        (("nav", "arm", "takeoff"), 0, "on the ground here: take off first"),
        (("altitude",), 0, "on the ground here"),
        (("takeoff",), 0, "not armed here"),
        (("arm", "takeoff", "nav", "disarm"), 3, "land it before disarming"),
    ],
)
def test_the_first_step_out_of_order_is_refused_with_its_index(names, index, words):
    with pytest.raises(StepOrderError) as refused:
        check(names)
    assert refused.value.extra == {"step_index": index}
    assert str(refused.value).startswith(f"step {index} (") and words in str(refused.value)


def test_the_planners_own_steps_are_not_blamed_and_indices_are_the_callers():
    # A preparation prefix of two (arm, takeoff) the caller did not write: its list starts at 0.
    listed = steps("arm", "takeoff", "land", "nav")
    with pytest.raises(StepOrderError) as refused:
        check_order(listed, airborne=False, armed=False, index_of=[None, None, 0, 1])
    assert refused.value.extra == {"step_index": 1}
    assert "after the land at step 0" in str(refused.value)
