"""Shared geometry for the Mission Planner tests: areas drawn in metres on the seed's field."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from dronefleet.geo.ned import LocalFrame
from dronefleet.geo.types import LLA, NED

#: A field near the University of Aveiro (the seed's experiments), 5 m above sea level.
ORIGIN = LLA(40.6300, -8.6580, 5.0)


@pytest.fixture
def origin() -> LLA:
    return ORIGIN


@pytest.fixture
def to_latlon() -> Callable[[list[tuple[float, float]]], list[tuple[float, float]]]:
    """Points given as (east, north) metres from ORIGIN -> [lat, lon] pairs."""
    frame = LocalFrame(ORIGIN)

    def convert(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
        return [(p.lat, p.lon) for p in (frame.to_lla(NED(n, e)) for e, n in points)]

    return convert


@pytest.fixture
def rect(to_latlon) -> Callable[..., list[tuple[float, float]]]:
    """``rect(width_e, length_n, east0=0, north0=0)``: a rectangle's corners as [lat, lon]."""

    def make(width_e: float, length_n: float, east0: float = 0.0, north0: float = 0.0):
        corners = [(0, 0), (0, length_n), (width_e, length_n), (width_e, 0)]
        return to_latlon([(east0 + e, north0 + n) for e, n in corners])

    return make


@pytest.fixture
def at() -> Callable[..., LLA]:
    """``at(east, north, up=0)``: a position in metres from ORIGIN."""
    frame = LocalFrame(ORIGIN)

    def make(east: float, north: float, up: float = 0.0) -> LLA:
        return frame.to_lla(NED(north, east, -up))

    return make
