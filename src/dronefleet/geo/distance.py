"""Distances, bearings and offsets between geographic positions (WGS84).

Distances and bearings are geodesics on the ellipsoid (geographiclib), horizontal only; offsets go
through the local NED frame of :mod:`dronefleet.geo.ned`, the frame the vehicle navigates in.
"""

from __future__ import annotations

from geographiclib.geodesic import Geodesic

from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED

_GEODESIC = Geodesic.WGS84
_INVERSE_MASK = Geodesic.DISTANCE | Geodesic.AZIMUTH


def distance_m(a: LLA, b: LLA) -> float:
    """Horizontal geodesic distance from ``a`` to ``b`` in metres (altitudes ignored)."""
    return float(_GEODESIC.Inverse(a.lat, a.lon, b.lat, b.lon, Geodesic.DISTANCE)["s12"])


def bearing_deg(a: LLA, b: LLA) -> float:
    """Initial geodesic bearing from ``a`` to ``b``, degrees clockwise from north in [0, 360)."""
    azimuth = _GEODESIC.Inverse(a.lat, a.lon, b.lat, b.lon, _INVERSE_MASK)["azi1"]
    return float(azimuth) % 360.0


def offset(a: LLA, north_m: float, east_m: float, up_m: float = 0.0) -> LLA:
    """The position ``north_m`` north, ``east_m`` east and ``up_m`` above ``a`` (local NED)."""
    return ned_to_lla(NED(north_m, east_m, -up_m), a)
