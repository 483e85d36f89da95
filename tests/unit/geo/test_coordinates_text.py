"""Coordinates typed into the maps' search box (geo/coordinates_text.py): what a person types
gives the place they meant, and anything ambiguous is not a place at all."""

from __future__ import annotations

import pytest

from dronefleet.geo.coordinates_text import CoordinateError, parse_coordinates

AVEIRO = (40.63, -8.66)


@pytest.mark.parametrize(
    "text",
    [
        "40.63, -8.66",
        "40.63,-8.66",
        "40.63 -8.66",
        "40.63; -8.66",
        "  40.63 ,  -8.66 ",
        "40.63N 8.66W",
        "40.63 N, 8.66 W",
        "N40.63 W8.66",
        "n 40.63 w 8.66",
        "8.66W 40.63N",
        "40°37'48\"N 8°39'36\"W",
        "40°37'48\"N, 8°39'36\"W",
        "40° 37' 48\" N 8° 39' 36\" W",
        "40°37\u203248\u2033N 8°39\u203236\u2033W",  # primes
        "40\u00ba37\u201948\u201dN 8\u00ba39\u201936\u201dW",  # what some keyboards give
        "40°37'48''N 8°39'36''W",
        "40°37.8'N 8°39.6'W",
        "40°37'48\" -8°39'36\"",
        "40 37 48 N 8 39 36 W",
        "40 37.8 N 8 39.6 W",
        "40.63° -8.66°",
    ],
)
def test_the_ways_people_write_a_position_all_give_it(text):
    lat, lon = parse_coordinates(text)
    assert lat == pytest.approx(AVEIRO[0], abs=1e-9) and lon == pytest.approx(AVEIRO[1], abs=1e-9)


def test_the_southern_and_western_hemispheres_and_the_signs():
    assert parse_coordinates("33°51'S 151°12'E") == pytest.approx((-33.85, 151.2))
    assert parse_coordinates("-33.85, 151.2") == pytest.approx((-33.85, 151.2))
    assert parse_coordinates("0, 0") == (0.0, 0.0)
    assert parse_coordinates("-0°30' 0°30'") == pytest.approx((-0.5, 0.5))


@pytest.mark.parametrize(
    "text",
    [
        "QUAD_1", "Aveiro", "Rua de Aveiro 10", "M1a2b3c4", "40.63", "E1", "N1",
        "40.63, -8.66, 12",  # a third number (an altitude?) is not guessed at
        "40 37 48 8 39 36",  # which numbers go together is a guess
        "30' 40°", "40.63 -8.66 N", "", "   ",
    ],
)  # fmt: skip
def test_what_is_not_a_position_is_not_read_as_one(text):
    assert parse_coordinates(text) is None


@pytest.mark.parametrize(
    ("text", "reason"),
    [
        ("91, 0", "latitude 91"),
        ("0, 181", "longitude 181"),
        ("40 75 0 N 8 0 0 W", "75 minutes"),
        ("40°30'61\"N 8°W", "61 seconds"),
        ("40.5°30'N 8°W", "whole"),
        ("-40S 8W", "minus sign"),
        ("40N 8S", "two latitudes"),
        ("8E 40W", "two longitudes"),
    ],
)
def test_an_impossible_position_is_refused_with_the_reason(text, reason):
    with pytest.raises(CoordinateError, match=reason):
        parse_coordinates(text)
