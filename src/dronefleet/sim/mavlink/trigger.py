"""The simulated Copter's camera trigger by distance (MAV_CMD_DO_SET_CAM_TRIGG_DIST).

As ArduPilot's camera library does: a distance of zero stops it; param3 = 1 takes one picture at
once; otherwise a picture is taken each time the vehicle is at least that far (horizontally) from
where the last one was taken. Surveys use it to photograph along a line without stopping, which
is how QGroundControl's surveys are flown (issue 17).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from dronefleet.geo.types import NED


class DistanceTrigger:
    def __init__(self, shoot: Callable[[], dict[str, Any] | None]) -> None:
        self._shoot = shoot
        self.distance_m = 0.0
        self._last: tuple[float, float] | None = None

    def set_distance(self, distance_m: float, *, shoot_now: bool = False) -> None:
        self.distance_m = max(0.0, float(distance_m))
        self._last = None
        if shoot_now:
            self._shoot()

    def shot_at(self, where: NED) -> None:
        """A picture was taken here (by the trigger or by any other command)."""
        self._last = (where.n, where.e)

    def update(self, where: NED) -> None:
        if self.distance_m <= 0:
            return
        if self._last is None:
            self._last = (where.n, where.e)
            return
        if math.dist(self._last, (where.n, where.e)) >= self.distance_m:
            self._shoot()
            self._last = (where.n, where.e)
