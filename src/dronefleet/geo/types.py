"""Coordinate value types: LLA on the wire, local NED inside the vehicle (STYLE.md)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, slots=True)
class LLA:
    """WGS84 latitude and longitude in degrees, altitude above mean sea level in metres."""

    lat: float
    lon: float
    alt_m: float = 0.0

    def __post_init__(self) -> None:
        if not (-90.0 <= self.lat <= 90.0) or not (-180.0 <= self.lon <= 180.0):
            raise ValueError(f"position out of range: lat {self.lat}, lon {self.lon}")
        if not all(map(math.isfinite, (self.lat, self.lon, self.alt_m))):
            raise ValueError("position has a non-finite coordinate")

    @classmethod
    def many(cls, lat: np.ndarray, lon: np.ndarray, alt_m: float = 0.0) -> list[LLA]:
        """Positions from arrays, checked as the constructor checks one, all at once: a plan's
        10,000 waypoints were a tenth of its planning time one by one (issue 11)."""
        lat, lon = np.asarray(lat, dtype=float), np.asarray(lon, dtype=float)
        if lat.size and not (
            np.isfinite(lat).all() and np.isfinite(lon).all() and math.isfinite(alt_m)
        ):
            raise ValueError("position has a non-finite coordinate")
        if lat.size and (np.abs(lat).max() > 90.0 or np.abs(lon).max() > 180.0):
            raise ValueError("position out of range")
        out = []
        new, put = object.__new__, object.__setattr__
        for a, o in zip(lat.tolist(), lon.tolist(), strict=True):
            p = new(cls)  # checked above: the frozen fields are set as the constructor would
            put(p, "lat", a)
            put(p, "lon", o)
            put(p, "alt_m", alt_m)
            out.append(p)
        return out


@dataclass(frozen=True, slots=True)
class NED:
    """Metres north, east and down of a home point (down: home altitude minus altitude)."""

    n: float
    e: float
    d: float = 0.0

    def __add__(self, other: NED) -> NED:
        return NED(self.n + other.n, self.e + other.e, self.d + other.d)

    def __sub__(self, other: NED) -> NED:
        return NED(self.n - other.n, self.e - other.e, self.d - other.d)

    def scaled(self, k: float) -> NED:
        return NED(self.n * k, self.e * k, self.d * k)

    @property
    def horizontal_m(self) -> float:
        return math.hypot(self.n, self.e)

    @property
    def norm_m(self) -> float:
        return math.sqrt(self.n * self.n + self.e * self.e + self.d * self.d)
