"""How long a route takes to fly: what the automatic angle compares (stage 2's score).

The planner's estimator (:mod:`dronefleet.ground.planner.estimate`) replays mission steps in LLA
with the vehicle model; choosing an angle compares a few candidate routes before any of them is
turned into steps, so it would replay each (milliseconds per route). The score here is length
plus a turn cost instead, in seconds at cruise speed: the route's metres, :attr:`RouteTime.turn_m`
for each heading change over :data:`STOP_TURN_DEG` (a turn the drone slows down for; through a
waypoint on a straight run, a stop-mode swath's, the estimator keeps its speed within its 2 m),
plus the hold at each stop that does something. Of a turn cost of 0, 5, 10, 20, 40 and 80 m, 5
gave both the shortest paths and the quickest flights by the estimator over the fields of
bench/coverage_vs_f2c.py (a trapezoid from rest at every waypoint, tried first, picked routes
the estimator flew slower). Candidates are compared, not promised.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dronefleet.ground.planner.coverage.path import Kind, RoutePoint, route_xy
from dronefleet.ground.planner.estimate import DEFAULT_MODEL

#: A heading change over this (degrees) at a waypoint is a stop in the route's time.
STOP_TURN_DEG = 45.0


@dataclass(frozen=True)
class RouteTime:
    """Seconds to fly route points: length and turns at cruise speed (see the module docstring)."""

    speed_mps: float = DEFAULT_MODEL.max_speed_mps
    turn_m: float = 5.0  # what a turn costs, in metres of cruise

    def of(self, points: list[RoutePoint], hold_s: float = 0.0) -> float:
        """Seconds to fly ``points`` in order, holding ``hold_s`` at each working stop."""
        return self.timed(points, hold_s)[0]

    def timed(self, points: list[RoutePoint], hold_s: float = 0.0) -> tuple[float, float]:
        """(:meth:`of`, the route's length in metres), its legs measured once: a bound checked
        after every gap closed wants both (:func:`~.candidate.beaten`)."""
        xy = route_xy(points)
        d = np.hypot(*np.diff(xy, axis=0).T) if len(xy) > 1 else np.zeros(0)
        length = float(d.sum()) if len(xy) > 1 else 0.0
        keep = d > 1e-9
        legs, steps = d[keep], np.diff(xy, axis=0)[keep]
        work = sum(1 for p in points if p.kind is Kind.WORK)
        if len(legs) == 0:
            return work * hold_s, length
        # The drone stops where the route turns; through a waypoint on a straight run (a stop-
        # mode swath's) it keeps its speed, reached within the estimator's 2 m.
        heading = np.arctan2(steps[:, 1], steps[:, 0])
        turn = np.abs((np.diff(heading) + np.pi) % (2 * np.pi) - np.pi)
        stops = int((turn > np.radians(STOP_TURN_DEG)).sum()) + 1
        metres = float(legs.sum()) + self.turn_m * stops
        return metres / self.speed_mps + work * hold_s, length
