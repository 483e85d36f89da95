"""Steady wind: the air moves, the position controller has to fight it.

A :class:`Wind` is the velocity of the air over the ground (north/east, m/s). The vehicle's
controller commands ground velocity but its airspeed is limited, so flying upwind is slower and
hovering in wind draws more current (the battery model is driven by airspeed).
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class Wind:
    """Air velocity over the ground: ``n_mps`` towards north, ``e_mps`` towards east."""

    n_mps: float = 0.0
    e_mps: float = 0.0

    @classmethod
    def from_direction(cls, speed_mps: float, from_deg: float) -> Wind:
        """Meteorological convention: ``from_deg`` is where the wind blows FROM (0 = north)."""
        to_rad = math.radians(from_deg + 180.0)
        return cls(speed_mps * math.cos(to_rad), speed_mps * math.sin(to_rad))

    @property
    def speed_mps(self) -> float:
        return math.hypot(self.n_mps, self.e_mps)

    @property
    def from_deg(self) -> float:
        return (math.degrees(math.atan2(self.e_mps, self.n_mps)) + 180.0) % 360.0


CALM = Wind()
