"""Which rally point a drone sent home early lands at (messaging/fence.py, issue 14)."""

from __future__ import annotations

from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.messaging.fence import Geofence, RallyPoint, nearest_rally

HOME = LLA(40.63, -8.659, 10.0)


def at(n: float, e: float) -> LLA:
    return ned_to_lla(NED(n, e), HOME)


def rally(n: float, e: float) -> RallyPoint:
    p = at(n, e)
    return RallyPoint(lat=p.lat, lon=p.lon, alt_m=12)


def box(n0: float, e0: float, n1: float, e1: float) -> list[list[float]]:
    return [[p.lat, p.lon] for p in (at(n0, e0), at(n0, e1), at(n1, e1), at(n1, e0))]


def test_the_nearest_rally_point_nearer_than_home_wins():
    points = [rally(100, 0), rally(70, 10), rally(200, 0)]
    assert nearest_rally(points, at(80, 0), HOME) == points[1]


def test_home_wins_when_it_is_nearer_than_every_rally_point():
    assert nearest_rally([rally(100, 0)], at(30, 0), HOME) is None
    assert nearest_rally([], at(30, 0), HOME) is None


def test_a_rally_point_behind_an_exclusion_zone_is_passed_over():
    points = [rally(80, 20), rally(55, 0)]
    fence = Geofence(inclusion=box(-50, -50, 150, 150), exclusions=[box(75, 5, 85, 15)])
    assert nearest_rally(points, at(80, 0), HOME) == points[0]  # without the fence
    assert nearest_rally(points, at(80, 0), HOME, fence) == points[1]
