"""Where simulated vehicles start: home points spread around a centre."""

from __future__ import annotations

import math

from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED


def homes_around(centre: LLA, count: int, spacing_m: float = 15.0) -> list[LLA]:
    """``count`` home points on a circle around ``centre``, ``spacing_m`` apart."""
    if count <= 1:
        return [centre][:count]
    radius = spacing_m / (2 * math.sin(math.pi / count))
    return [
        ned_to_lla(
            NED(
                radius * math.cos(2 * math.pi * i / count),
                radius * math.sin(2 * math.pi * i / count),
            ),
            centre,
        )
        for i in range(count)
    ]
