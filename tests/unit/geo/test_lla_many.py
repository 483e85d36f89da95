"""LLA.many: positions from arrays, checked as LLA's constructor checks one (issue 11)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dronefleet.geo.types import LLA


def test_many_gives_what_the_constructor_gives():
    lat, lon = np.array([40.63, -89.9, 0.0]), np.array([-8.659, 179.9, 0.0])
    assert LLA.many(lat, lon, 12.5) == [LLA(a, o, 12.5) for a, o in zip(lat, lon, strict=True)]
    assert LLA.many(np.array([]), np.array([])) == []


@pytest.mark.parametrize(
    ("lat", "lon", "alt"),
    [(95.0, 0.0, 0.0), (0.0, -181.0, 0.0), (math.nan, 0.0, 0.0), (0.0, 0.0, math.inf)],
)
def test_many_refuses_what_the_constructor_refuses(lat, lon, alt):
    with pytest.raises(ValueError):
        LLA(lat, lon, alt)
    with pytest.raises(ValueError):
        LLA.many(np.array([1.0, lat]), np.array([1.0, lon]), alt)
