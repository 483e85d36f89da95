"""LLA <-> local NED around a home point (seed 4.1.2.2, Figure 4.13).

The seed's Navigation Processor converted waypoints to NED with a spherical formula adapted from the
dRonin GCS (:func:`seed_lla_to_ned`). On a sphere of radius ``a`` it is off by a few metres per
kilometre (about 6.7 m north at the equator, 2 m at Aveiro), because the Earth's meridian and
prime-vertical radii differ from ``a``. We keep it for comparison only and navigate with an exact
local tangent plane on the WGS84 ellipsoid:

* horizontal: the target is taken at the home altitude, converted geodetic -> ECEF and rotated into
  the NED frame at home; its north and east components are N and E;
* vertical: ``D = home.alt_m - target.alt_m``, a plain geodetic height difference, so "10 m up"
  means 10 m on the altimeter, not 10 m along the home vertical.

The inverse solves the forward map with a few Newton steps (< 1 mm within 10 km). Per-home
constants live in a :class:`LocalFrame`; the module functions use a small cache of frames because
the physics and navigation code call them per tick for many vehicles.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from dronefleet.geo.types import LLA, NED

#: WGS84 semi-major axis (m) and first eccentricity squared.
WGS84_A = 6_378_137.0
WGS84_F = 1.0 / 298.257223563
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)

_DEG = math.pi / 180.0
_INVERSE_STEPS = 6
_INVERSE_TOLERANCE_M = 1e-6


def _wrap_lon(lon_deg: float) -> float:
    """Longitude in [-180, 180)."""
    return (lon_deg + 180.0) % 360.0 - 180.0


class LocalFrame:
    """The local NED frame at one home point; ``to_ned`` and ``to_lla`` are inverse maps."""

    __slots__ = ("_cos_lat0", "_home_n", "_m0", "_n0", "_sin_lat0", "_x0", "_z0", "home")

    def __init__(self, home: LLA) -> None:
        self.home = home
        lat0 = home.lat * _DEG
        self._sin_lat0 = math.sin(lat0)
        self._cos_lat0 = math.cos(lat0)
        h = home.alt_m
        w = math.sqrt(1.0 - WGS84_E2 * self._sin_lat0 * self._sin_lat0)
        self._n0 = WGS84_A / w + h  # prime-vertical radius at home, plus height
        self._m0 = WGS84_A * (1.0 - WGS84_E2) / (w * w * w) + h  # meridian radius, plus height
        # Home in ECEF, rotated about the z axis so that home's longitude is 0.
        self._home_n = WGS84_A / w
        self._x0 = (self._home_n + h) * self._cos_lat0
        self._z0 = (self._home_n * (1.0 - WGS84_E2) + h) * self._sin_lat0

    def _horizontal(self, lat_deg: float, dlon_deg: float) -> tuple[float, float]:
        """North and east of the point (lat, home.lon + dlon) taken at the home altitude."""
        lat = lat_deg * _DEG
        dlon = dlon_deg * _DEG
        sin_lat = math.sin(lat)
        cos_lat = math.cos(lat)
        h = self.home.alt_m
        n_rad = WGS84_A / math.sqrt(1.0 - WGS84_E2 * sin_lat * sin_lat)
        r = (n_rad + h) * cos_lat
        dx = r * math.cos(dlon) - self._x0
        dz = (n_rad * (1.0 - WGS84_E2) + h) * sin_lat - self._z0
        north = -self._sin_lat0 * dx + self._cos_lat0 * dz
        east = r * math.sin(dlon)
        return north, east

    def to_ned(self, target: LLA) -> NED:
        """``target`` in this frame (metres north, east, down of home)."""
        north, east = self._horizontal(target.lat, _wrap_lon(target.lon - self.home.lon))
        return NED(north, east, self.home.alt_m - target.alt_m)

    def to_lla(self, ned: NED) -> LLA:
        """The geographic position ``ned`` metres from home (inverse of :meth:`to_ned`)."""
        # First guess from the local radii; then Newton steps with the diagonal Jacobian, which
        # is exact to ~1e-3 within 10 km, so each step gains about three digits.
        lat = self.home.lat + ned.n / self._m0 / _DEG
        cos_lat0 = max(self._cos_lat0, 1e-12)
        dlon = ned.e / (self._n0 * cos_lat0) / _DEG
        for _ in range(_INVERSE_STEPS):
            north, east = self._horizontal(lat, dlon)
            err_n = ned.n - north
            err_e = ned.e - east
            if abs(err_n) < _INVERSE_TOLERANCE_M and abs(err_e) < _INVERSE_TOLERANCE_M:
                break
            sin_lat = math.sin(lat * _DEG)
            w = math.sqrt(1.0 - WGS84_E2 * sin_lat * sin_lat)
            m = WGS84_A * (1.0 - WGS84_E2) / (w * w * w) + self.home.alt_m
            n_rad = WGS84_A / w + self.home.alt_m
            cos_lat = max(math.cos(lat * _DEG), 1e-12)
            lat += err_n / m / _DEG
            dlon += err_e / (n_rad * cos_lat) / _DEG
        lat = max(-90.0, min(90.0, lat))
        return LLA(lat, _wrap_lon(self.home.lon + dlon), self.home.alt_m - ned.d)

    def horizontal_many(self, lat_deg: np.ndarray, dlon_deg: np.ndarray) -> np.ndarray:
        """:meth:`_horizontal` of arrays of points at once: rows (north, east)."""
        lat, dlon = np.radians(lat_deg), np.radians(dlon_deg)
        sin_lat, cos_lat = np.sin(lat), np.cos(lat)
        h = self.home.alt_m
        n_rad = WGS84_A / np.sqrt(1.0 - WGS84_E2 * sin_lat * sin_lat)
        r = (n_rad + h) * cos_lat
        dx = r * np.cos(dlon) - self._x0
        dz = (n_rad * (1.0 - WGS84_E2) + h) * sin_lat - self._z0
        return np.vstack((-self._sin_lat0 * dx + self._cos_lat0 * dz, r * np.sin(dlon)))

    def to_lla_many(self, north: np.ndarray, east: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`to_lla` of arrays of points at once (a plan's thousands of waypoints): the
        same Newton steps, on every point until all are within tolerance; (lat, lon) in
        degrees, at the home altitude."""
        lat = self.home.lat + north / self._m0 / _DEG
        dlon = east / (self._n0 * max(self._cos_lat0, 1e-12)) / _DEG
        for _ in range(_INVERSE_STEPS):
            got_n, got_e = self.horizontal_many(lat, dlon)
            err_n, err_e = north - got_n, east - got_e
            if np.all(np.abs(err_n) < _INVERSE_TOLERANCE_M) and np.all(
                np.abs(err_e) < _INVERSE_TOLERANCE_M
            ):
                break
            sin_lat = np.sin(np.radians(lat))
            w = np.sqrt(1.0 - WGS84_E2 * sin_lat * sin_lat)
            m = WGS84_A * (1.0 - WGS84_E2) / (w * w * w) + self.home.alt_m
            n_rad = WGS84_A / w + self.home.alt_m
            cos_lat = np.maximum(np.cos(np.radians(lat)), 1e-12)
            lat = lat + err_n / m / _DEG
            dlon = dlon + err_e / (n_rad * cos_lat) / _DEG
        return np.clip(lat, -90.0, 90.0), (self.home.lon + dlon + 180.0) % 360.0 - 180.0


@lru_cache(maxsize=256)
def local_frame(home: LLA) -> LocalFrame:
    """The (cached) local frame at ``home``."""
    return LocalFrame(home)


def lla_to_ned(target: LLA, home: LLA) -> NED:
    """``target`` as metres north, east and down of ``home`` (exact WGS84 tangent plane)."""
    return local_frame(home).to_ned(target)


def ned_to_lla(ned: NED, home: LLA) -> LLA:
    """The position ``ned`` metres from ``home``; round-trips :func:`lla_to_ned` to < 1 mm."""
    return local_frame(home).to_lla(ned)


# The seed's constants, verbatim (Figure 4.13), including the truncated degree-to-radian factor.
SEED_DEGREE_TO_RADIAN = 0.017453293
SEED_EARTH_RADIUS_M = 6378137.0


def seed_lla_to_ned(target: LLA, home: LLA) -> NED:
    """Figure 4.13 verbatim: a sphere of radius 6378137 m. For comparison, not for navigation.

    It is off by a few metres per kilometre (see the module docstring and the tests).
    """
    k = SEED_DEGREE_TO_RADIAN
    radius = home.alt_m + SEED_EARTH_RADIUS_M
    north = radius * (target.lat - home.lat) * k
    east = math.cos(home.lat * k) * radius * (target.lon - home.lon) * k
    return NED(north, east, home.alt_m - target.alt_m)
