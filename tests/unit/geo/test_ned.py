"""The Navigation Processor's coordinate conversion (seed 4.1.2.2, Figure 4.13), checked against
PROJ's topocentric frame and geographiclib's geodesics."""

from __future__ import annotations

import math

import pytest
from geographiclib.geodesic import Geodesic
from hypothesis import given, settings
from hypothesis import strategies as st
from pyproj import Transformer

from dronefleet.geo.distance import bearing_deg, distance_m, offset
from dronefleet.geo.ned import LocalFrame, lla_to_ned, ned_to_lla, seed_lla_to_ned
from dronefleet.geo.types import LLA, NED

LATITUDES = [0.0, 40.6, 60.0, -35.0]  # equator, Aveiro (the seed's flights), north, south
AZIMUTHS = range(0, 360, 15)
CM = 0.01
MM = 0.001


def topocentric(home: LLA) -> Transformer:
    """PROJ: geodetic (lat, lon, h) -> ECEF -> east/north/up at ``home``."""
    return Transformer.from_pipeline(
        "+proj=pipeline"
        " +step +proj=axisswap +order=2,1"
        " +step +proj=unitconvert +xy_in=deg +xy_out=rad"
        " +step +proj=cart +ellps=WGS84"
        f" +step +proj=topocentric +ellps=WGS84 +lat_0={home.lat} +lon_0={home.lon}"
        f" +h_0={home.alt_m}"
    )


def one_km_away(home: LLA, azimuth_deg: float, alt_m: float) -> LLA:
    g = Geodesic.WGS84.Direct(home.lat, home.lon, azimuth_deg, 1000.0)
    return LLA(g["lat2"], g["lon2"], alt_m)


@pytest.mark.parametrize("lat", LATITUDES)
def test_north_east_match_proj_topocentric_at_1_km_in_every_direction(lat: float) -> None:
    home = LLA(lat, -8.65, 120.0)
    proj = topocentric(home)
    for azimuth in AZIMUTHS:
        target = one_km_away(home, azimuth, alt_m=150.0)
        # Our horizontal part is the target taken at the home altitude.
        east, north, _ = proj.transform(target.lat, target.lon, home.alt_m)
        ned = lla_to_ned(target, home)
        assert ned.n == pytest.approx(north, abs=CM)
        assert ned.e == pytest.approx(east, abs=CM)
        assert ned.d == pytest.approx(-30.0)  # 30 m above home: plain height difference


@pytest.mark.parametrize("lat", LATITUDES)
def test_a_geodesic_of_1_km_is_1_km_in_the_local_frame(lat: float) -> None:
    home = LLA(lat, 151.2, 0.0)  # on the ellipsoid, where geodesics live
    for azimuth in AZIMUTHS:
        ned = lla_to_ned(one_km_away(home, azimuth, 0.0), home)
        assert ned.n == pytest.approx(1000.0 * math.cos(math.radians(azimuth)), abs=CM)
        assert ned.e == pytest.approx(1000.0 * math.sin(math.radians(azimuth)), abs=CM)


def test_the_frame_crosses_the_antimeridian() -> None:
    home = LLA(-17.0, 179.999, 0.0)
    target = offset(home, 0.0, 500.0)
    assert target.lon < 0  # wrapped to -179.99...
    assert lla_to_ned(target, home).e == pytest.approx(500.0, abs=MM)


homes = st.builds(
    LLA,
    lat=st.floats(-80.0, 80.0),
    lon=st.floats(-180.0, 180.0),
    alt_m=st.floats(-100.0, 3000.0),
)
offsets = st.builds(
    NED,
    n=st.floats(-10_000.0, 10_000.0),
    e=st.floats(-10_000.0, 10_000.0),
    d=st.floats(-500.0, 500.0),
)


@settings(max_examples=300, deadline=None)
@given(home=homes, ned=offsets)
def test_ned_to_lla_round_trips_to_a_millimetre_within_10_km(home: LLA, ned: NED) -> None:
    back = lla_to_ned(ned_to_lla(ned, home), home)
    assert (back - ned).norm_m < MM


@settings(max_examples=200, deadline=None)
@given(home=homes, ned=offsets)
def test_lla_to_ned_round_trips_to_a_millimetre_on_the_ground(home: LLA, ned: NED) -> None:
    target = LocalFrame(home).to_lla(ned)
    again = ned_to_lla(lla_to_ned(target, home), home)
    ground_error_m = Geodesic.WGS84.Inverse(target.lat, target.lon, again.lat, again.lon)["s12"]
    assert ground_error_m < MM
    assert again.alt_m == pytest.approx(target.alt_m, abs=MM)


def seed_error_at_1_km(lat: float) -> float:
    home = LLA(lat, -8.65, 10.0)
    return max(
        (seed_lla_to_ned(t, home) - lla_to_ned(t, home)).horizontal_m
        for t in (one_km_away(home, az, home.alt_m) for az in AZIMUTHS)
    )


def test_the_seed_formula_is_a_few_metres_off_at_1_km_which_is_why_we_do_not_fly_it() -> None:
    # Figure 4.13 uses one sphere of radius 6378137 m for both axes. The ellipsoid's meridian
    # radius is 6335 km at the equator and 6363 km at Aveiro, its prime-vertical radius 6387 km
    # there: a waypoint 1 km away lands metres off, beyond the seed's own 2 m arrival tolerance.
    errors = {lat: seed_error_at_1_km(lat) for lat in LATITUDES}
    print("seed formula error at 1 km (m):", {k: round(v, 2) for k, v in errors.items()})
    assert 6.0 < errors[0.0] < 7.5  # worst at the equator (meridian radius is shortest there)
    assert 1.5 < errors[40.6] < 3.5  # Aveiro, where the seed flew
    assert all(0.5 < e < 10.0 for e in errors.values())


def test_the_seed_formula_agrees_on_altitude_and_on_the_home_point() -> None:
    home = LLA(40.6, -8.65, 10.0)
    assert seed_lla_to_ned(home, home) == NED(0.0, 0.0, 0.0)
    assert seed_lla_to_ned(LLA(40.6, -8.65, 35.0), home).d == pytest.approx(-25.0)


def test_distance_and_bearing_are_geodesic_and_offset_inverts_them() -> None:
    aveiro = LLA(40.6303, -8.6575, 5.0)
    there = offset(aveiro, north_m=300.0, east_m=400.0, up_m=20.0)
    assert distance_m(aveiro, there) == pytest.approx(500.0, abs=CM)
    assert bearing_deg(aveiro, there) == pytest.approx(math.degrees(math.atan2(400, 300)), abs=1e-3)
    assert there.alt_m == pytest.approx(25.0)
    assert bearing_deg(aveiro, offset(aveiro, -100.0, 0.0)) == pytest.approx(180.0, abs=1e-6)
    assert bearing_deg(aveiro, offset(aveiro, 0.0, -100.0)) == pytest.approx(270.0, abs=1e-3)
