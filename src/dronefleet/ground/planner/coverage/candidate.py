"""One angle's route in the coverage pipeline (:mod:`.pipeline`), and which route is flown.

A :class:`Candidate` carries an angle's cells, route, points and what they cost; the pipeline
routes a shortlist of them, closes the gaps of the likeliest and flies :func:`chosen`. Route
times (:mod:`.cost`) are close to the estimator's, not equal: routes within :data:`SAME_TIME`
of the quickest count as equally quick, and the shortest of them is flown.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from shapely.geometry import Polygon

from dronefleet.ground.planner.coverage.decompose import Cell
from dronefleet.ground.planner.coverage.path import PathBuilder, RoutePoint, route_xy
from dronefleet.ground.planner.coverage.route import Routed
from dronefleet.ground.planner.coverage.uncovered import Gap

#: Routes whose times differ by less than this fraction fly as long: the shorter one wins.
#: RouteTime is that close to the estimator, no closer: at 1 % a star's route at 14.5° (533 m)
#: won over its tip axis's (513 m), which RouteTime put 2.5 % slower and the estimator flies
#: 5 s quicker (144 against 149 s).
SAME_TIME = 0.03

#: Whether a route is past what it may cost (:meth:`GapFiller.fill` stops there).
Over = Callable[[list[RoutePoint]], bool]


@dataclass
class Candidate:
    """One angle's route (sweep frame), what it leaves uncovered, and what it costs to fly."""

    angle: float
    sweep_area: Polygon
    cells: list[Cell]
    builder: PathBuilder
    start: tuple[float, float]
    routed: Routed | None = None
    points: list[RoutePoint] = field(default_factory=list)
    hold_s: float = 0.0  # at each working stop
    left: list[Polygon] = field(default_factory=list)  # gaps left uncovered
    time_s: float = 0.0
    length_m: float = 0.0
    gaps: list[Gap] | None = None  # what the route leaves, before spurs
    guess: float = 0.0  # its time with a spur to each gap (seconds)
    #: "swaths" at ``angle``, "rings" (:mod:`.contour`) or "headland" (:mod:`.headland`)
    pattern: str = "swaths"

    @property
    def key(self) -> tuple[float, float]:
        return round(self.time_s, 3), round(self.length_m, 3)


def quicker(timed: list[tuple[float, float]]) -> int:
    """Of (seconds, metres) routes, the shortest within :data:`SAME_TIME` of the quickest;
    the first of equals."""
    fastest = min(t for t, _ in timed)
    near = [k for k, (t, _) in enumerate(timed) if t <= fastest * (1.0 + SAME_TIME)]
    return min(near, key=lambda k: round(timed[k][1], 3))


def quicker_live(timed: list[tuple[float, float]], live: list[bool]) -> int:
    """:func:`quicker` among the routes still ``live`` (a route a bound stopped part-way, see
    :func:`beaten`, cannot be chosen, however short it was left); among all if none is."""
    keep = [k for k, ok in enumerate(live) if ok] or list(range(len(timed)))
    return keep[quicker([timed[k] for k in keep])]


def route_length(points: list[RoutePoint]) -> float:
    """The length of the path through ``points`` (m)."""
    xy = route_xy(points)
    return float(np.hypot(*np.diff(xy, axis=0).T).sum()) if len(xy) > 1 else 0.0


def beaten(time_s: float, length_m: float, closed: list[tuple[float, float]]) -> bool:
    """Whether a route of ``time_s`` and ``length_m`` that only grows (closing gaps adds to a
    route) can no longer be :func:`chosen` over ``closed`` (seconds, metres), being after them.

    It cannot once it is past :data:`SAME_TIME` of the quickest of them, or once one of them
    that stays within SAME_TIME of the quickest whatever the route ends at is no longer than it
    (the shortest wins, the first of equals). The second is what lets the pipeline stop closing
    an angle that only had to be shorter: a pond's second angle began 24 m longer than the first
    one ended (20 ms of closing gaps for nothing), a traced outline's caught up midway."""
    if not closed:
        return False
    fastest = min(t for t, _ in closed)
    if time_s > fastest * (1.0 + SAME_TIME):
        return True
    near = min(fastest, time_s) * (1.0 + SAME_TIME)
    return any(t <= near and round(m, 3) <= round(length_m, 3) for t, m in closed)


def chosen(closed: list[Candidate]) -> Candidate:
    """The shortest of the routes within :data:`SAME_TIME` of the quickest (the closed form is
    no closer than that to the estimator); the first of equals."""
    fastest = min(c.time_s for c in closed)
    return min(
        (c for c in closed if c.time_s <= fastest * (1.0 + SAME_TIME)),
        key=lambda c: round(c.length_m, 3),
    )
