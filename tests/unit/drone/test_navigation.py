"""Algorithm 1: a goal is reached inside the tolerance cylinder (Figure 4.15)."""

import pytest

from dronefleet.drone.navigation import Tolerance, reached
from dronefleet.geo.types import NED


@pytest.mark.parametrize(
    ("actual", "expected"),
    [
        (NED(0, 0, -10), True),
        (NED(1.9, 0, -10), True),
        (NED(1.5, 1.5, -10), False),  # 2.12 m horizontally
        (NED(0, 0, -8.1), True),
        (NED(0, 0, -8.0), False),  # exactly 2 m: strict inequality, as in the seed
        (NED(0, 0, -12.5), False),
    ],
)
def test_algorithm_1_cylinder(actual, expected):
    assert reached(NED(0, 0, -10), actual, Tolerance(2, 2)) is expected


def test_tolerances_are_configurable():
    assert reached(NED(0, 0, -10), NED(4, 0, -10), Tolerance(5, 1))
    assert not reached(NED(0, 0, -10), NED(0, 0, -11.5), Tolerance(5, 1))
