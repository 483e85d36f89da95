"""The geofence check a mission passes before it is accepted (ground/planner/geofence.py)."""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.ground.planner.geofence import FenceBreach, Geofence, check_share

HOME = LLA(40.63, -8.659, 10.0)


def corners(*neds: tuple[float, float]) -> list[list[float]]:
    return [[p.lat, p.lon] for p in (ned_to_lla(NED(n, e), HOME) for n, e in neds)]


def go(n: float, e: float, up: float = 10.0) -> dict:
    p = ned_to_lla(NED(n, e), HOME)
    return {"command": "navigate", "lat": p.lat, "lon": p.lon, "altitude_delta": up}


SITE = corners((-10, -10), (-10, 110), (110, 110), (110, -10))
ROAD = corners((40, -20), (40, 120), (50, 120), (50, -20))  # across the site, east-west
SHED = corners((70, 70), (70, 90), (90, 90), (90, 70))


def check(fence: Geofence, steps: list[dict], *, home: bool = True) -> None:
    check_share(fence, "QUAD_1", HOME, HOME, steps, returns_home=home)


def test_a_share_inside_the_site_and_clear_of_the_zones_passes() -> None:
    fence = Geofence(inclusion=SITE, exclusions=[SHED], ceiling_m=60)
    check(fence, [{"command": "takeoff", "value": 10}, go(30, 0), go(30, 60), go(0, 60)])


def test_a_waypoint_outside_the_site_is_named() -> None:
    with pytest.raises(FenceBreach, match=r"QUAD_1 step 2 \(navigate\) at .* outside"):
        check(Geofence(inclusion=SITE), [{"command": "arm"}, go(30, 0), go(30, 130)])


def test_a_straight_leg_across_an_exclusion_zone_is_refused() -> None:
    fence = Geofence(inclusion=SITE, exclusions=[ROAD])
    with pytest.raises(FenceBreach, match=r"from step 0 .* to step 1 .* crosses exclusion zone 1"):
        check(fence, [go(30, 0), go(60, 0)], home=False)


def test_the_way_home_counts() -> None:
    fence = Geofence(exclusions=[ROAD])
    beyond = ned_to_lla(NED(60, 0), HOME)  # a drone already past the road
    steps = [go(70, 0)]
    check_share(fence, "QUAD_1", beyond, HOME, steps, returns_home=False)
    with pytest.raises(FenceBreach, match=r"from step 0 .* to its way home crosses"):
        check_share(fence, "QUAD_1", beyond, HOME, steps, returns_home=True)


def test_the_ceiling_holds_for_waypoints_and_takeoff() -> None:
    fence = Geofence(ceiling_m=50)
    check(fence, [go(10, 10, 50)])
    with pytest.raises(FenceBreach, match="80 m up, above the fence ceiling of 50 m"):
        check(fence, [go(10, 10, 80)])
    with pytest.raises(FenceBreach, match="takes off to 70 m"):
        check(fence, [{"command": "takeoff", "value": 70}])


@pytest.mark.parametrize(
    "bad",
    [
        {"inclusion": [[40.0, -8.0], [40.1, -8.0]]},  # two corners
        {"inclusion": [[91.0, 0.0], [40.0, 0.0], [40.0, 1.0]]},  # not a latitude
        {"exclusions": [[[40.0, -8.0, 3.0], [40.1, -8.0], [40.1, -8.1]]]},  # three numbers
        {"ceiling_m": -5},
        {"inclusion": [], "exclusions": [[]]},  # empty shapes (the fuzzer's 500, once)
        {"inclusion": [[40.0, -8.0], [40.1, -8.0], [40.1, float("nan")]]},
        {"inclusion": SITE, "height": 3},  # an unknown key
    ],
)
def test_a_malformed_fence_is_refused(bad: dict) -> None:
    with pytest.raises(ValidationError):
        Geofence.model_validate(bad)
