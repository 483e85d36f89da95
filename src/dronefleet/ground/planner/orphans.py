"""Lost drones are traffic (issue 26): an orphan's last place, and where it may have drifted.

A drone the Drone Identifier has lost may still be in the air: its companion computer died (a
process killed, a board browned out) and its autopilot holds where it was told to go, or its
link to the ground is cut and it flies on. Measured on SITL before this: the replacement of a
drone killed mid-share was sent to exactly its last point and passed 0.23 m from it at the same
height. So every plan keeps clear of an orphan until the ground hears it again:

- where it was last known to be (its last telemetry, else its last heartbeat), and the way to
  the goal its telemetry named (a GUIDED autopilot flies on there and stops), as a row of
  hovering points (:data:`POINT_SPACING_M` apart);
- around each, a keep-out radius of :data:`MIN_RADIUS_M` plus its drift: its last ground speed
  times the time since it was last heard (growing along the plan), capped at
  :data:`DRIFT_CAP_M` (:data:`GOAL_DRIFT_CAP_M` when its goal is known: it stops there), or the
  cap when its speed is not known.

Vertically the separation minimum holds (:data:`~.separation.VERTICAL_M`): another drone may
pass on another layer. :mod:`.deconflict` flies a replacement's steps near an orphan
:data:`~.deconflict.AROUND_M` above or below it (see there).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dronefleet.geo.ned import lla_to_ned
from dronefleet.geo.types import LLA
from dronefleet.ground.planner.trajectory import SAMPLE_S, Trajectory

#: Metres another drone keeps from an orphan horizontally (when within the vertical minimum):
#: the 10 m asked for, and 2 m for the difference between a predicted path and the flight.
MIN_RADIUS_M = 12.0
#: Largest drift added to it: a copter at 10 m/s stops within 20 m (2.5 m/s²).
DRIFT_CAP_M = 20.0
#: ... when the orphan's goal is known: it flies there and stops (the way there is kept out).
GOAL_DRIFT_CAP_M = 5.0
#: Metres between the hovering points along an orphan's way to its goal (a row of circles of
#: radius r this far apart keeps sqrt(r² - 1) m clear of every point between them).
POINT_SPACING_M = 2.0
MAX_POINTS = 60
#: Vehicle seconds a growing keep-out is followed along a plan (then it stays as it is).
HORIZON_S = 1200.0


@dataclass(frozen=True)
class Orphan:
    """A drone in the air that the ground no longer hears."""

    drone_id: str
    last: LLA  # where it was last known to be
    goal: LLA | None = None  # where it was flying to, if its telemetry said
    speed_mps: float | None = None  # its last ground speed
    age_s: float | None = None  # seconds since it was last heard

    @property
    def cap_m(self) -> float:
        return GOAL_DRIFT_CAP_M if self.goal is not None else DRIFT_CAP_M

    def radius_m(self, after_s: np.ndarray | float = 0.0) -> np.ndarray:
        """The keep-out radius ``after_s`` seconds from now."""
        after = np.asarray(after_s, dtype=float)
        if self.speed_mps is None or self.age_s is None:
            return np.full_like(after, MIN_RADIUS_M + self.cap_m)
        drift = np.minimum(self.speed_mps * (self.age_s + after), self.cap_m)
        return MIN_RADIUS_M + drift

    @property
    def widest_m(self) -> float:
        """The radius it grows to."""
        return float(self.radius_m(HORIZON_S))

    def points(self) -> list[LLA]:
        """Its last position, then along the way to its goal."""
        if self.goal is None:
            return [self.last]
        span = lla_to_ned(self.goal, self.last)
        length = math.sqrt(span.n**2 + span.e**2 + span.d**2)
        count = min(MAX_POINTS, max(1, math.ceil(length / POINT_SPACING_M)))
        return [
            LLA(
                self.last.lat + (self.goal.lat - self.last.lat) * k / count,
                self.last.lon + (self.goal.lon - self.last.lon) * k / count,
                self.last.alt_m + (self.goal.alt_m - self.last.alt_m) * k / count,
            )
            for k in range(count + 1)
        ]

    def paths(self, origin: LLA) -> list[Trajectory]:
        """One hovering path per point, carrying the keep-out radius sample by sample."""
        grows_s = 0.0
        if self.speed_mps and self.age_s is not None:
            grows_s = min(HORIZON_S, max(0.0, self.cap_m / self.speed_mps - self.age_s))
        samples = math.ceil(grows_s / SAMPLE_S) + 1
        radius = self.radius_m(np.arange(samples) * SAMPLE_S)
        found: list[Trajectory] = []
        for point in self.points():
            here = lla_to_ned(point, origin)
            found.append(
                Kept(
                    self.drone_id,
                    np.full(samples, here.n),
                    np.full(samples, here.e),
                    np.full(samples, -here.d),
                    np.ones(samples, dtype=bool),
                    label="lost",
                    keep_out_m=radius,
                )
            )
        return found

    def near(self, where: LLA, margin_m: float = 0.0) -> bool:
        """Whether ``where`` lies within its widest keep-out (plus ``margin_m``) horizontally."""
        reach = self.widest_m + margin_m
        return any(horizontal_m(where, p) < reach for p in self.points())

    def heights_m(self, origin: LLA) -> tuple[float, float]:
        """The lowest and highest it may be, metres above ``origin``."""
        ups = [-lla_to_ned(p, origin).d for p in self.points()]
        return min(ups), max(ups)


def horizontal_m(a: LLA, b: LLA) -> float:
    d = lla_to_ned(a, b)
    return math.hypot(d.n, d.e)


@dataclass(frozen=True)
class Kept(Trajectory):
    """A path others keep ``keep_out_m`` (per sample) from horizontally, not just the minimum."""

    keep_out_m: np.ndarray = field(default_factory=lambda: np.zeros(1))

    def _each(
        self, change: Callable[[np.ndarray], np.ndarray], delay_s: float | None = None
    ) -> Trajectory:
        return Kept(
            self.drone_id,
            change(self.n_m),
            change(self.e_m),
            change(self.up_m),
            change(self.in_air),
            self.delay_s if delay_s is None else delay_s,
            self.label,
            change(self.keep_out_m),
        )


def keep_out_of(path: Trajectory) -> np.ndarray | None:
    """The per-sample radius others keep from ``path`` (None: the separation minimum)."""
    return path.keep_out_m if isinstance(path, Kept) else None


def of_drone(
    drone_id: str,
    position: LLA,
    *,
    telemetry: dict[str, Any] | None = None,
    speed_mps: float | None = None,
    age_s: float | None = None,
) -> Orphan:
    """An orphan from what the ground last heard: its latest ``telemetry`` (position, velocity,
    goal) when there is some, else its heartbeat's ``position`` and ``speed_mps``."""
    goal = None
    if telemetry:
        if all(isinstance(telemetry.get(k), int | float) for k in ("lat", "lon", "alt_m")):
            position = LLA(telemetry["lat"], telemetry["lon"], telemetry["alt_m"])
        vn, ve = telemetry.get("vn"), telemetry.get("ve")
        if isinstance(vn, int | float) and isinstance(ve, int | float):
            speed_mps = math.hypot(vn, ve)
        g = [telemetry.get(k) for k in ("goal_lat", "goal_lon", "goal_alt_m")]
        if all(isinstance(v, int | float) for v in g):
            goal = LLA(float(g[0]), float(g[1]), float(g[2]))  # type: ignore[arg-type]
    return Orphan(drone_id, position, goal, speed_mps, age_s)
