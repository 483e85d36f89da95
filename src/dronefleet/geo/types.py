"""Coordinate value types: LLA on the wire, local NED inside the vehicle (STYLE.md)."""

from __future__ import annotations

import math
from dataclasses import dataclass


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
