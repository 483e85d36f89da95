"""What a coverage area accepts (issue 30): its target, spacing and outline.

A coverage target defaults to 100 % and outside 50-100 % is refused; a zero, negative or NaN
spacing (or altitude) is refused naming the field; an outline that crosses itself, or holes
outside it, overlapping or crossing themselves, are refused by the planner in one sentence naming
the problem.
"""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from dronefleet.ground.planner.coverage import AreaSpec, plan_area
from support.f2c_fields import ring, spec


@pytest.mark.parametrize("value", [49.9, 100.1, -5.0, 1000.0])
def test_a_coverage_target_out_of_range_is_refused_in_one_sentence(value):
    with pytest.raises(ValidationError) as refused:
        spec("L-shaped", target=value)
    message = refused.value.errors()[0]["msg"]
    assert "coverage_target_pct must be between 50 and 100" in message
    assert message.count(".") <= 1 and "\n" not in message


def test_the_default_target_is_100_percent():
    assert spec("L-shaped").coverage_target_pct == 100.0
    assert AreaSpec.model_validate(spec("L-shaped", target=97.5).model_dump()).coverage_target_pct
    assert spec("L-shaped", target=50).coverage_target_pct == 50.0


def square(size: float, x0: float = 0.0, y0: float = 0.0) -> list[tuple[float, float]]:
    return [(x0, y0), (x0 + size, y0), (x0 + size, y0 + size), (x0, y0 + size)]


@pytest.mark.parametrize(
    ("outline", "holes", "spacing", "reason"),
    [
        ([(0, 0), (60, 60), (60, 0), (0, 60)], [], 10, "not simple (its edges cross"),
        (square(60), [square(10, 100, 100)], 10, "hole 0 is not inside the area"),
        (square(60), [square(10, 10, 10), square(10, 40, 40), square(100, -20, -20)], 10,
         "hole 2 is not inside the area"),
        (square(60), [square(20, 10, 10), square(20, 20, 20)], 10, "holes 0 and 1 overlap"),
        (square(60), [[(10, 10), (30, 30), (30, 10), (10, 30)]], 10, "hole 0 is not simple"),
    ],
    ids=["self-intersecting", "hole outside", "third hole larger", "holes overlap", "bow hole"],
)  # fmt: skip
def test_bad_areas_are_refused_with_one_sentence_naming_the_problem(
    outline, holes, spacing, reason
):
    with pytest.raises(ValueError, match=None) as refused:
        plan_area(
            AreaSpec(polygon=ring(outline), holes=[ring(h) for h in holes], spacing_m=spacing)
        )
    message = str(refused.value)
    assert reason in message
    assert "\n" not in message and message.count(";") <= 1


@pytest.mark.parametrize(
    ("fields", "name"),
    [({"spacing_m": 0}, "spacing_m"), ({"spacing_m": -3}, "spacing_m"),
     ({"spacing_m": float("nan")}, "spacing_m"), ({"altitude_m": 0}, "altitude_m")],
)  # fmt: skip
def test_zero_or_negative_spacing_is_refused_naming_the_field(fields, name):
    with pytest.raises(ValidationError) as refused:
        AreaSpec(polygon=ring(square(60)), **fields)
    errors = refused.value.errors()
    assert len(errors) == 1 and errors[0]["loc"] == (name,)
